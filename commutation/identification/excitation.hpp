#pragma once
// How well identification data determine a model (docs/commutation.md,
// "Fit quality"): the condition of the regressors a fit is linear in, the
// parameters the data leave unexcited, and the stretches of the stroke
// where the data carry no samples or no current of a coil. Shared by the
// PGNN and the spline fits. No I/O.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "commutation/identification/dataset.hpp"

namespace clm::identification {

/// The parameters a fit is linear in (the spline's coefficients; the PGNN's
/// physics part and output layers at its trained hidden layers), judged on
/// the data part of the normal matrix, 1/N Σ m mᵀ, without the penalties.
struct RegressorQuality {
  /// Condition number of the column-scaled regressor matrix over the
  /// excited columns and without the dependent directions (the square root
  /// of the scaled normal matrix's); 0 before it is computed.
  double condition = 0.0;
  int parameters = 0;
  /// Columns the data (nearly) leave out: their parameter is set by the
  /// penalties alone (smoothness, Λ, the small ridge), not by measurement.
  int unexcited = 0;
  /// Directions of the excited columns' parameter space the data cannot
  /// tell apart (regressor condition beyond kMaxRegressorCondition along
  /// them): a tanh neuron saturated over the stroke duplicates its layer's
  /// bias, for instance. They change no prediction on the data; the
  /// penalties set them.
  int dependent = 0;
};

/// A run of linear parameters judged together: a spline's coefficients of
/// one function (compared with their median), or one parameter on its own.
/// `counted` false: columns beyond the data by construction (a spline's
/// end functions, centred outside the data's range), never unexcited.
struct ColumnGroup {
  int first = 0;
  int count = 1;
  bool counted = true;
};

/// A column of a group of three or more is unexcited below this share of
/// the group's median mean square; any column below 1e-12 of the largest.
inline constexpr double kUnexcitedShare = 0.02;

/// Along a direction whose regressor condition exceeds this, the data do
/// not determine the parameters (eigenvalue of the scaled normal matrix
/// below 1e-16 of the largest: the rounding of double precision).
inline constexpr double kMaxRegressorCondition = 1e8;

/// RegressorQuality of `data_gram` (symmetric, columns in `groups`, which
/// cover every column once).
RegressorQuality regressor_quality(const Eigen::MatrixXd& data_gram, const std::vector<ColumnGroup>& groups);

/// What the data lack over a stretch of the stroke.
enum class ExcitationLack { kNoSamples, kNoCurrentA, kNoCurrentB };

struct ExcitationGap {
  double low_m = 0.0;
  double high_m = 0.0;
  ExcitationLack lack = ExcitationLack::kNoSamples;
};

/// Bins of an eighth of the pole pitch over the data's positions: a bin
/// lacks samples below kSparseShare of the mean count per bin, and a coil's
/// current where its RMS is below kSparseShare of that coil's RMS over all
/// samples (its gain column is then not measured there). Adjacent bins with
/// the same lack are merged, in order of position.
inline constexpr double kSparseShare = 0.1;
std::vector<ExcitationGap> excitation_gaps(const CoilSetDataset& data, double pole_pitch_m);

/// "no samples", "no current of coil a", "no current of coil b".
const char* describe(ExcitationLack lack);

/// One line per finding a user should act on: unexcited parameters and
/// each excitation gap (dependent directions are reported, not warned of).
std::vector<std::string> identification_warnings(const RegressorQuality& regressors,
                                                 const std::vector<ExcitationGap>& gaps);

}  // namespace clm::identification
