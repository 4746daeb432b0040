#pragma once
// The validation score of a model (Σ over coil sets of its held-out F_y MSE
// over the physics-only fit's; CapacityTrial::validation_score) with its
// standard error, and the choice of a law from such scores with a tie rule
// (docs/commutation.md, "The recommendation"). The held-out data are the
// contiguous blocks of identification::split_contiguous_blocks; the blocks
// are the independent samples the uncertainty is estimated from. No I/O.

#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace clm::data {

/// One held-out block of one coil set: the F_y squared errors summed over its
/// samples [N²], of the model and of the physics-only fit on the same samples.
struct HeldOutBlock {
  double model_N2 = 0.0;
  double physics_N2 = 0.0;
};

/// Per coil set, its held-out blocks in the split's order.
using HeldOutBlocks = std::vector<std::vector<HeldOutBlock>>;

/// A score (or a difference of two) and its standard error; NaN where it
/// cannot be estimated (no blocks, or a coil set with fewer than two).
struct ScoreEstimate {
  double value = std::numeric_limits<double>::quiet_NaN();
  double standard_error = std::numeric_limits<double>::quiet_NaN();
};

/// The sums of `squared_errors` [N²] over consecutive runs of
/// `block_samples` entries (identification::DataSplit::validation_blocks).
/// Throws std::invalid_argument when the runs do not add up to its size.
std::vector<double> block_sums(const Eigen::VectorXd& squared_errors, const std::vector<std::size_t>& block_samples);

/// One coil set's blocks from the per-sample held-out squared F_y errors of
/// the model and the physics-only fit (IdentificationReport's
/// model_validation_y_N2, physics_validation_y_N2). Throws
/// std::invalid_argument when the sizes disagree.
std::vector<HeldOutBlock> held_out_blocks(const Eigen::VectorXd& model_N2, const Eigen::VectorXd& physics_N2,
                                          const std::vector<std::size_t>& block_samples);

/// The score Σ_l R_l, R_l = Σ_b model_lb / Σ_b physics_lb (equal to the
/// ratio of the MSEs: both sums run over the same samples), and its standard
/// error with the blocks as independent samples: the ratio estimator's,
/// linearised, SE² = Σ_l B_l/(B_l−1) Σ_b z_lb², z_lb = (model_lb −
/// R_l·physics_lb) / Σ_b physics_lb, with B_l the blocks of coil set l. With
/// equal physics per block this is the standard error of the mean of the
/// per-block ratios. Coil sets whose physics error is not positive are left
/// out, as the score leaves them out.
ScoreEstimate held_out_score(const HeldOutBlocks& blocks);

/// score(a) − score(b) on the same blocks, with the standard error of the
/// paired difference: the same formula on z^a_lb − z^b_lb, so that what the
/// two laws share (the sensor's noise in a block, a hard stretch of the
/// stroke) cancels. Throws std::invalid_argument when a and b do not have the
/// same coil sets and blocks.
ScoreEstimate paired_difference(const HeldOutBlocks& a, const HeldOutBlocks& b);

/// The physics-only fit as a law of its own: every block's model error set
/// to its physics error (score = coil sets, z = 0, so that its paired
/// difference with a law has that law's own standard error).
HeldOutBlocks physics_only(const HeldOutBlocks& any_law);

/// Two laws are a tie when their scores differ by less than this many
/// standard errors of the paired difference. 2: about 95 % two-sided for a
/// normal difference. With four held-out blocks per coil set the standard
/// error is itself uncertain by about a third, so a smaller k calls noise a
/// win; a larger one (3) makes nearly every comparison a tie and leaves the
/// choice to the preference order (docs/commutation.md, "The recommendation").
inline constexpr double kTieStandardErrors = 2.0;

/// A law competing for the recommendation. `blocks` empty (nothing held out)
/// leaves `score` as given, without a standard error.
struct LawScore {
  std::string law;
  HeldOutBlocks blocks;
  ScoreEstimate score;  ///< from blocks when there are any (law_score)
};

/// A LawScore with its score from `blocks`.
LawScore law_score(std::string law, HeldOutBlocks blocks);

/// score(a) − score(b): paired on their blocks when both have the same
/// ones, else the difference of two independent estimates (standard errors
/// added in quadrature; NaN when either is unknown).
ScoreEstimate score_difference(const LawScore& a, const LawScore& b);

/// The choice among laws. `recommended` has the lowest score unless the tie
/// rule chose another; `runner_up` is the best-scoring other law (lowest
/// score when the recommended one is not the lowest; "" when there is none).
struct Verdict {
  std::string recommended;
  bool tie = false;                ///< chosen by the preference order among laws tied with the lowest score
  std::vector<std::string> tied;   ///< the laws within k standard errors of the lowest score, in preference order
  std::string runner_up;
  /// runner-up's score − recommended's: negative when the tie rule chose a
  /// law with a higher score.
  double margin_score = std::numeric_limits<double>::quiet_NaN();
  /// margin_score over the standard error of their paired difference
  /// (infinite when that error is 0; NaN when unknown).
  double margin_standard_errors = std::numeric_limits<double>::quiet_NaN();
};

/// Chooses among `laws`, given in order of preference on a tie: the law with
/// the lowest score, unless other laws score within k standard errors of
/// their paired difference with it; then the first of those tied (the lowest
/// included) in the given order. Without standard errors two laws tie only
/// on equal scores. Throws std::invalid_argument on no laws or a score that
/// is NaN.
Verdict choose_law(const std::vector<LawScore>& laws, double k = kTieStandardErrors);

}  // namespace clm::data
