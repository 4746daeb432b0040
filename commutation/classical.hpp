#pragma once
// The classical (idealised sinusoidal) model of a coil set, eq. (6)-(8), and the
// classical commutation law (11)/(12) with the corrected force share (docs/commutation.md §1).

#include <span>

#include "commutation/transform.hpp"
#include "commutation/types.hpp"

namespace clm {

/// Parameters of the ideal model (7) of one coil set.
struct ClassicalCoilSet {
  double motor_constant_N_per_A = 0.0;  ///< k^l [N/A], > 0
  double phase_offset_rad = 0.0;        ///< ζ^l [rad]
  double orthogonal_ratio = 0.0;        ///< μ [-]: share of the motor constant acting along x
  double lever_arm_m = 0.0;             ///< d^l [m]: position of the coil set relative to the centre of mass
};

/// K^l(y) of eq. (7) reduced to the two star currents [i_a, i_b] (column a minus
/// column c, column b minus column c). Units [N/A; N/A; N·m/A].
CoilGain classical_gain(const ClassicalCoilSet& coil_set, double position_m, double pole_pitch_m);

/// The physical parameters A, B of eq. (24) that reproduce eq. (7) exactly:
/// K(y) = A·cos(2πy/d_m) + B·sin(2πy/d_m). Since K is of that form, A = K(0) and
/// B = K(d_m/4).
void classical_physics_parameters(const ClassicalCoilSet& coil_set, CoilGain& a, CoilGain& b);

/// Phase currents [i_a, i_b] of eq. (12) for one coil set commanded with
/// magnitude `magnitude_N` at commutation angle 2πy/d_m + phase_offset_rad:
/// i = [sin η̂, sin(η̂ + 2π/3)]·magnitude/k̂.
Eigen::Vector2d sinusoidal_currents(double magnitude_N, double commutation_angle_rad,
                                    double motor_constant_N_per_A);

/// Phase currents the drive applies for a setpoint (eq. 18/19): the fixed law with
/// its own k̂_d, ζ̂_d and the commanded offset Δ added to its angle.
Eigen::Vector2d drive_phase_currents(const DriveCommutation& drive, const DriveSetpoint& setpoint,
                                     double position_m, double pole_pitch_m);

/// Calibrated classical commutation constants of one coil set (Algorithm 1 output).
struct ClassicalEstimate {
  double motor_constant_N_per_A = 0.0;  ///< k̂^l [N/A]
  double phase_offset_rad = 0.0;        ///< ζ̂^l [rad]
};

/// Driving-force share of each coil set, corrected eq. (12):
/// F_y^{l*} = (k̂^l)² / Σ_m (k̂^m)² · F_y^*. Writes estimates.size() values to `share_N`.
void classical_force_share(std::span<const ClassicalEstimate> estimates, double driving_force_N,
                           std::span<double> share_N);

/// Classical commutation (12): currents [i_a^l, i_b^l] for a desired driving force,
/// L = estimates.size() coil sets; with `driving_gain_N_per_A`, also the y row
/// of classical_gain per current (the model's ∂F_y/∂i). No allocation.
void classical_currents(std::span<const ClassicalEstimate> estimates, double pole_pitch_m,
                        double position_m, double driving_force_N, CurrentVector& currents_A,
                        CurrentVector* driving_gain_N_per_A = nullptr);

/// Classical commutation (12) expressed as setpoints of a drive with fixed
/// commutation: magnitude k̂_d/k̂^l·F_y^{l*} and offset ζ̂^l − ζ̂_d, put into the
/// range of `convention`. Writes estimates.size() setpoints. No allocation.
void classical_setpoints(std::span<const ClassicalEstimate> estimates, const DriveCommutation& drive,
                         double driving_force_N, PhaseConvention convention,
                         std::span<DriveSetpoint> setpoints);

}  // namespace clm
