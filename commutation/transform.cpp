#include "commutation/transform.hpp"

#include <cmath>

#include "commutation/elementary.hpp"

namespace clm {

double wrap_angle_rad(double angle_rad) {
  double wrapped = std::remainder(angle_rad, kTwoPi);  // in [−π, π]
  if (wrapped <= -kPi) wrapped += kTwoPi;
  return wrapped;
}

Eigen::Matrix2d gamma_matrix(const DriveCommutation& drive, double position_m, double pole_pitch_m) {
  const double eta = electrical_angle_rad(position_m, pole_pitch_m) + drive.phase_offset_rad;
  const double inv_k = 1.0 / drive.motor_constant_N_per_A;
  Eigen::Matrix2d gamma;
  const auto [s0, c0] = elementary::sin_cos(eta);
  const auto [s1, c1] = elementary::sin_cos(eta + kTwoPiOverThree);
  gamma << s0, c0, s1, c1;
  return inv_k * gamma;
}

Eigen::Matrix2d gamma_inverse(const DriveCommutation& drive, double position_m, double pole_pitch_m) {
  const double eta = electrical_angle_rad(position_m, pole_pitch_m) + drive.phase_offset_rad;
  const auto [s0, c0] = elementary::sin_cos(eta);
  // sin/cos of η + 2π/3 by the angle-sum rule: one sin/cos pair per call.
  const double sin_120 = elementary::sin(kTwoPiOverThree);
  const double s1 = s0 * -0.5 + c0 * sin_120;
  const double c1 = c0 * -0.5 - s0 * sin_120;
  // det [[s0, c0], [s1, c1]] = sin(η − (η + 2π/3)) = −sin(2π/3).
  const double inv_det = -1.0 / elementary::sin(kTwoPiOverThree);
  Eigen::Matrix2d inverse;
  inverse << c1, -c0, -s1, s0;
  return (drive.motor_constant_N_per_A * inv_det) * inverse;
}

Eigen::Vector2d transform_forward(const DriveSetpoint& setpoint) {
  const auto [s, c] = elementary::sin_cos(setpoint.delta_rad);
  return {c * setpoint.magnitude_N, s * setpoint.magnitude_N};
}

DriveSetpoint transform_inverse(const Eigen::Vector2d& f12_N, PhaseConvention convention) {
  if (f12_N.x() == 0.0 && f12_N.y() == 0.0) return {0.0, 0.0};
  double delta = elementary::atan2(f12_N.y(), f12_N.x());  // (−π, π]
  // Forces are far from overflow, so sqrt does what hypot would, cheaper.
  double magnitude = std::sqrt(f12_N.x() * f12_N.x() + f12_N.y() * f12_N.y());
  if (convention == PhaseConvention::kSignedMagnitude) {
    // Fold into (−π/2, π/2]; the magnitude takes the sign.
    if (delta > 0.5 * kPi) {
      delta -= kPi;
      magnitude = -magnitude;
    } else if (delta <= -0.5 * kPi) {
      delta += kPi;
      magnitude = -magnitude;
    }
  }
  return {magnitude, delta};
}

DriveSetpoint setpoint_from_currents(const DriveCommutation& drive, double position_m,
                                     double pole_pitch_m, const Eigen::Vector2d& currents_A,
                                     PhaseConvention convention) {
  const Eigen::Vector2d f12 = gamma_inverse(drive, position_m, pole_pitch_m) * currents_A;
  return transform_inverse(f12, convention);
}

}  // namespace clm
