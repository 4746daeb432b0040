#pragma once
// Identification of the electromagnetic part of one coil set from force data
// (Algorithm 2): the physics-only fit θ*_phy, the ridge least-squares solve of
// eq. (31), the PGNN by Levenberg–Marquardt (Ceres) with seeded restarts, and
// the spline model class as one regularised linear least-squares problem.
// No I/O.

#include <cstdint>
#include <functional>
#include <string>

#include "commutation/identification/dataset.hpp"
#include "commutation/model.hpp"

namespace clm {

/// Data-term cost per direction (mean squared error, eq. 26 without the
/// regularisation) of coil set `coil_set` of `model` on `data`. Evaluates the
/// model through ElectromagneticModel, independently of the training code.
DirectionCost coil_set_cost(const ElectromagneticModel& model, int coil_set, const CoilSetDataset& data);

/// Physics-only model: A, B of eq. (24) without networks, least squares per
/// direction. This is θ*_phy of eq. (26) (paper-notes item 8).
void fit_physics_only(const CoilSetDataset& data, double pole_pitch_m, CoilGain& a, CoilGain& b);

/// Input normalisation mapping the positions in `data` to [−1, 1].
PositionNormalisation normalisation_for(const Eigen::VectorXd& position_m);

/// How Levenberg–Marquardt treats the parameters in which the PGNN is linear
/// (θ_L of eq. 29; docs/commutation.md, "Identification").
enum class PgnnSolver {
  kVariableProjection,  ///< θ_L by eq. (31) at every θ_NL, LM on θ_NL alone (Kaufman's Jacobian)
  kJointSchur,          ///< LM on θ_L and θ_NL together, θ_L eliminated by the Schur complement
};

struct PgnnOptions {
  int column_hidden = 2;        ///< neurons of each column network of K̂ (paper: 2)
  int cogging_hidden = 16;      ///< neurons of the cogging network (paper: 16)
  double regularisation = 0.1;  ///< Λ = regularisation·I in eq. (26) (paper: 0.1)
  int restarts = 5;             ///< seeded random initialisations, best kept
  std::uint64_t seed = 1;
  int restart_iterations = 40;  ///< LM iterations per restart, on the decimated training set
  int restart_decimation = 8;   ///< every n-th training sample is used for the restarts
  int final_iterations = 100;   ///< LM iterations polishing the best restart
  int final_decimation = 2;     ///< every n-th training sample is used for the polish
  // At 1 kHz the experiments sample the stroke every 25-150 µm, far finer
  // than anything the networks resolve; the decimated sets keep every
  // position region. Eq. (31) at the end always uses all training samples.
  int threads = 2;
  PgnnSolver solver = PgnnSolver::kVariableProjection;
};

struct PgnnProgress {
  int restart = 0;      ///< 0-based; restarts == polishing step
  int restarts = 0;
  double cost = 0.0;    ///< eq. (26) at the end of this step
};

struct IdentificationReport {
  DirectionCost physics_training = DirectionCost::Zero();
  DirectionCost model_training = DirectionCost::Zero();
  DirectionCost physics_validation = DirectionCost::Zero();
  DirectionCost model_validation = DirectionCost::Zero();
  double regularised_cost = 0.0;  ///< eq. (26) of the final model on training data
  int best_restart = -1;
  int iterations = 0;             ///< LM iterations over all steps
  /// Proposition 4.1 per direction: the model's training data term does not
  /// exceed the physics-only one (eq. 32).
  bool proposition_holds[3] = {false, false, false};
};

/// Algorithm 2 for one coil set: returns A, B and the three networks. The
/// networks take `normalisation` of the position as input. Eq. (31) is
/// applied to the best parameters at the end, which guarantees eq. (32).
/// `progress` (optional) is called after every restart and the polish.
CoilSetModel identify_pgnn_coil_set(const CoilSetDataset& training, const CoilSetDataset& validation,
                                    double pole_pitch_m, const PositionNormalisation& normalisation,
                                    const PgnnOptions& options, IdentificationReport& report,
                                    const std::function<void(const PgnnProgress&)>& progress = {});

/// Eq. (31): ridge least squares of every parameter in which the PGNN is
/// linear (A, B and the output layers), direction by direction, with the
/// hidden layers of `coil_set` held fixed. Modifies `coil_set` in place.
void solve_linear_parameters(const CoilSetDataset& data, double pole_pitch_m,
                             const PositionNormalisation& normalisation, const CoilGain& physics_a,
                             const CoilGain& physics_b, double regularisation, CoilSetModel& coil_set);

struct SplineOptions {
  double knot_spacing_m = 0.0;  ///< 0: an eighth of the pole pitch
  double smoothing = 1e-6;      ///< weight of the squared second differences of the coefficients
  double regularisation = 0.1;  ///< Λ pulling A, B towards the physics-only fit
};

/// Spline model of one coil set: K̂ = A cos + B sin + Σ_j b_j(y)·[C_a,j, C_b,j],
/// F̂_cog = Σ_j b_j(y)·G_j on `basis`, solved as one regularised linear
/// least-squares problem per direction.
CoilSetModel identify_spline_coil_set(const CoilSetDataset& training, const CoilSetDataset& validation,
                                      double pole_pitch_m, const UniformCubicBasis& basis,
                                      const SplineOptions& options, IdentificationReport& report);

/// Knot grid covering `position_m` with spacing options.knot_spacing_m (or d_m/8).
UniformCubicBasis spline_basis_for(const Eigen::VectorXd& position_m, double pole_pitch_m, const SplineOptions& options);

}  // namespace clm
