#pragma once
// Input transformation for drives with fixed commutation, eq. (19)-(21) and (39):
// currents [i_a, i_b] <-> (F_1, F_2) = Γ(y)⁻¹ i <-> (magnitude, Δ).

#include "commutation/types.hpp"

namespace clm {

/// How T⁻¹ (eq. 21) resolves the sign of the force (docs/commutation.md §4).
enum class PhaseConvention {
  /// Magnitude carries the sign, Δ ∈ (−π/2, π/2]: Δ stays continuous when the
  /// force changes sign. Default; preferred by drives that rate-limit the phase.
  kSignedMagnitude,
  /// Magnitude ≥ 0, Δ ∈ (−π, π] from atan2: Δ jumps by π at every sign change.
  kNonNegativeMagnitude,
};

/// Γ(y) of eq. (20) for the drive's fixed k̂_d and ζ̂_d (docs/commutation.md §5), [A/N].
Eigen::Matrix2d gamma_matrix(const DriveCommutation& drive, double position_m, double pole_pitch_m);

/// Γ(y)⁻¹ in closed form (det Γ = −sin(2π/3)/k̂_d² never vanishes), [N/A].
Eigen::Matrix2d gamma_inverse(const DriveCommutation& drive, double position_m, double pole_pitch_m);

/// T of eq. (21): (magnitude, Δ) -> (F_1, F_2) = (cos Δ·m, sin Δ·m) [N].
Eigen::Vector2d transform_forward(const DriveSetpoint& setpoint);

/// T⁻¹ of eq. (21) with the chosen sign convention; T(T⁻¹(v)) = v for every v,
/// v = 0 included (it maps to magnitude 0, Δ = 0).
DriveSetpoint transform_inverse(const Eigen::Vector2d& f12_N, PhaseConvention convention);

/// Eq. (39): the setpoint that makes the drive apply `currents_A` = [i_a, i_b].
DriveSetpoint setpoint_from_currents(const DriveCommutation& drive, double position_m,
                                     double pole_pitch_m, const Eigen::Vector2d& currents_A,
                                     PhaseConvention convention);

/// Wraps an angle to (−π, π].
double wrap_angle_rad(double angle_rad);

}  // namespace clm
