#pragma once
// Data-based calibration of a coil set's motor constant and commutation phase
// offset: Algorithm 1 with the corrected update (docs/commutation.md §2) for any two
// distinct phase offsets, and a variant that is not biased by cogging
// (notes, "An observation to handle").

#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "commutation/bspline.hpp"

namespace clm {

/// One experiment of Algorithm 1: a single coil set driven by the drive's fixed
/// commutation with a constant offset `delta_rad` added to its angle.
struct CalibrationGroup {
  double delta_rad = 0.0;                     ///< Δ_i [rad]
  std::span<const double> position_m;         ///< y(t) [m]
  std::span<const double> magnitude_N;        ///< commanded magnitude F_y^{l*}(t) [N]
  std::span<const double> driving_force_N;    ///< measured F_y(t) [N]
};

/// How well the data determined a calibration (docs/commutation.md,
/// "Calibration's fit quality").
struct CalibrationQuality {
  /// One standard error of ĉ_1, ĉ_2 [-], from the residual and the
  /// regressors (independent residuals assumed, so a lower bound).
  double gain_ratio_standard_error[2] = {0.0, 0.0};
  /// σ_max/σ_min of the map from (k/k̂·cos φ, k/k̂·sin φ) to (ĉ_1, ĉ_2),
  /// (1 + |cos D|)/|sin D| for D = δ_2 − δ_1: 1 for offsets π/2 apart,
  /// growing without bound as they close.
  double separation_condition = 1.0;
  /// The variance inflation of ĉ_1, ĉ_2 by the offset b(y) fitted beside
  /// them (offset-robust only; 1 for Algorithm 1): large when the command
  /// moves with the position, so that a gain and an offset look alike.
  double offset_inflation[2] = {1.0, 1.0};
};

/// Limits above which a calibration warns (calibration_warnings): a ratio
/// known to worse than 10 %, offsets that hardly separate k and ζ, a ratio
/// five times less certain because of the offset fitted beside it.
inline constexpr double kMaxGainRatioRelativeError = 0.1;
inline constexpr double kMaxSeparationCondition = 20.0;
inline constexpr double kMaxOffsetInflation = 5.0;

struct CalibrationResult {
  double motor_constant_N_per_A = 0.0;  ///< k̂^l [N/A]
  double phase_offset_rad = 0.0;        ///< ζ̂^l [rad]
  double gain_ratio[2] = {0.0, 0.0};    ///< ĉ_1, ĉ_2 of eq. (14) [-]
  double residual_rms_N[2] = {0.0, 0.0};  ///< RMS of F_y − fit per group [N]
  CalibrationQuality quality;
};

/// The separation condition of two phase offsets (CalibrationQuality).
double separation_condition(double delta_1_rad, double delta_2_rad);

/// One sentence per limit a calibration exceeds (the three constants above),
/// naming the group and the figure; empty when the data excited everything.
std::vector<std::string> calibration_warnings(const double gain_ratio[2], const CalibrationQuality& quality);

/// Thrown when the groups cannot determine k̂ and ζ̂ (equal offsets, no data,
/// no excitation). The message says which.
class CalibrationError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Algorithm 1 (eq. 14 and corrected eq. 15). `drive_motor_constant_N_per_A`
/// and `drive_phase_offset_rad` are the k̂, ζ̂ the experiments ran with; the
/// groups may use any two offsets with sin(δ_2 − δ_1) ≠ 0.
CalibrationResult calibrate_classical(double drive_motor_constant_N_per_A, double drive_phase_offset_rad,
                                      const CalibrationGroup& first, const CalibrationGroup& second);

/// As calibrate_classical, but eq. (14) is fitted together with a
/// position-dependent offset b(y), shared by both groups and expanded in
/// `offset_basis`, so that forces that do not scale with the command (cogging,
/// cables) do not bias ĉ_i. `offset_ridge` regularises the offset coefficients
/// (per-sample units [N²/N²]); it only matters for knots without data.
CalibrationResult calibrate_classical_offset_robust(double drive_motor_constant_N_per_A,
                                                    double drive_phase_offset_rad,
                                                    const CalibrationGroup& first,
                                                    const CalibrationGroup& second,
                                                    const UniformCubicBasis& offset_basis,
                                                    double offset_ridge = 1e-6);

/// The update step (corrected eq. 15) alone: from the fitted ratios ĉ_1, ĉ_2 at
/// offsets δ_1, δ_2 to (k̂, ζ̂). Uses atan2 so that it also holds for ĉ_1 ≤ 0.
void calibration_update(double drive_motor_constant_N_per_A, double drive_phase_offset_rad,
                        double delta_1_rad, double c_1, double delta_2_rad, double c_2,
                        double& motor_constant_N_per_A, double& phase_offset_rad);

}  // namespace clm
