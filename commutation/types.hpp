#pragma once
// Shared fixed-size types of the commutation library.
//
// Forces are ordered [F_y, F_x, T_z] in [N, N, N·m] throughout: driving force,
// out-of-plane force, torque about z (paper Sec. 2.2). Coil-set currents are the
// two independent star currents [i_a, i_b] in [A]; i_c = -i_a - i_b (eq. 5).

#include <Eigen/Core>
#include <numbers>

namespace clm {

/// Largest number of coil sets any motor may have. Storage in the cycle is
/// sized for it, so the cycle never allocates.
inline constexpr int kMaxCoilSets = 8;
/// Two independent star currents per coil set.
inline constexpr int kMaxCurrents = 2 * kMaxCoilSets;

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;
inline constexpr double kTwoPiOverThree = 2.0 * std::numbers::pi / 3.0;

/// [F_y N, F_x N, T_z N·m].
using Wrench = Eigen::Vector3d;
/// Gain matrix of one coil set from [i_a, i_b] [A] to a wrench: K^l(y) of eq. (22) [N/A, N/A, N·m/A].
using CoilGain = Eigen::Matrix<double, 3, 2>;
/// Gain matrices of all coil sets side by side, 3 × 2L (eq. 9 / 35).
using StackedGain = Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::ColMajor, 3, kMaxCurrents>;
/// Currents of all coil sets, [i_a^1, i_b^1, ..., i_a^L, i_b^L] [A].
using CurrentVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxCurrents, 1>;

/// The commutation the drive applies itself and that cannot be changed
/// (Sec. 3): a motor constant and a phase offset common to all coil sets.
struct DriveCommutation {
  double motor_constant_N_per_A = 0.0;  ///< k̂_d [N/A]
  double phase_offset_rad = 0.0;        ///< ζ̂_d [rad]
};

/// Setpoint of one coil set for a drive with fixed commutation (eq. 18).
struct DriveSetpoint {
  double magnitude_N = 0.0;  ///< commutation magnitude F_y^{l*} [N]
  double delta_rad = 0.0;    ///< offset Δ^l added to the drive's commutation angle [rad]
};

/// What the drive takes as its setpoint (docs/servod.md, "Drive profile"):
/// magnitude and phase offset per coil set, commutated by the drive's own
/// fixed law (eq. 18/19, the paper's Fig. 5), or the phase currents
/// [i_a, i_b] per coil set directly (current-mode or dual-analog amplifiers,
/// Fig. 6/7 without the fixed-commutation block). Motor file key `drive.profile`.
enum class DriveProfile { kMagnitudePhase = 0, kPhaseCurrent = 1 };

/// "magnitude_phase" or "phase_current", as in the motor file.
inline const char* name(DriveProfile profile) noexcept {
  return profile == DriveProfile::kPhaseCurrent ? "phase_current" : "magnitude_phase";
}

/// Phase-current setpoint of one coil set for a drive with profile
/// phase_current: the two independent star currents, i_c = −i_a − i_b (eq. 5).
struct PhaseCurrentSetpoint {
  double ia_A = 0.0;  ///< i_a [A]
  double ib_A = 0.0;  ///< i_b [A]
};

/// Electrical angle 2π·y/d_m [rad] of a position (eq. 8 without the offset).
inline double electrical_angle_rad(double position_m, double pole_pitch_m) {
  return kTwoPi * position_m / pole_pitch_m;
}

}  // namespace clm
