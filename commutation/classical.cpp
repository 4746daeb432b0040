#include "commutation/classical.hpp"

#include <cmath>

#include "commutation/elementary.hpp"

namespace clm {

CoilGain classical_gain(const ClassicalCoilSet& coil_set, double position_m, double pole_pitch_m) {
  const double eta = electrical_angle_rad(position_m, pole_pitch_m) + coil_set.phase_offset_rad;
  const double scale = 2.0 / 3.0 * coil_set.motor_constant_N_per_A;
  const elementary::SinCos phase[3] = {elementary::sin_cos(eta), elementary::sin_cos(eta + kTwoPiOverThree),
                                       elementary::sin_cos(eta - kTwoPiOverThree)};
  CoilGain gain;
  for (int column = 0; column < 2; ++column) {
    // Star constraint (5): i_c = −i_a − i_b, so column j of the reduced matrix is
    // column j of eq. (7) minus its column c.
    const double sine = phase[column].sin - phase[2].sin;
    const double cosine = phase[column].cos - phase[2].cos;
    gain(0, column) = scale * sine;
    gain(1, column) = scale * coil_set.orthogonal_ratio * cosine;
    gain(2, column) = scale * coil_set.lever_arm_m * coil_set.orthogonal_ratio * cosine;
  }
  return gain;
}

void classical_physics_parameters(const ClassicalCoilSet& coil_set, CoilGain& a, CoilGain& b) {
  // Pick the offset so that the electrical angle is exactly 0 and π/2.
  a = classical_gain(coil_set, 0.0, 1.0);
  b = classical_gain(coil_set, 0.25, 1.0);
}

namespace {

/// [sin η, sin(η + 2π/3)]: the shape of phases a and b at commutation angle η.
Eigen::Vector2d phase_sines(double commutation_angle_rad) {
  return {elementary::sin(commutation_angle_rad), elementary::sin(commutation_angle_rad + kTwoPiOverThree)};
}

}  // namespace

Eigen::Vector2d sinusoidal_currents(double magnitude_N, double commutation_angle_rad,
                                    double motor_constant_N_per_A) {
  return magnitude_N / motor_constant_N_per_A * phase_sines(commutation_angle_rad);
}

Eigen::Vector2d drive_phase_currents(const DriveCommutation& drive, const DriveSetpoint& setpoint,
                                     double position_m, double pole_pitch_m) {
  const double angle =
      electrical_angle_rad(position_m, pole_pitch_m) + drive.phase_offset_rad + setpoint.delta_rad;
  return sinusoidal_currents(setpoint.magnitude_N, angle, drive.motor_constant_N_per_A);
}

void classical_force_share(std::span<const ClassicalEstimate> estimates, double driving_force_N,
                           std::span<double> share_N) {
  double sum_k2 = 0.0;
  for (const auto& estimate : estimates) sum_k2 += estimate.motor_constant_N_per_A * estimate.motor_constant_N_per_A;
  for (std::size_t l = 0; l < estimates.size(); ++l) {
    const double k = estimates[l].motor_constant_N_per_A;
    share_N[l] = k * k / sum_k2 * driving_force_N;
  }
}

void classical_currents(std::span<const ClassicalEstimate> estimates, double pole_pitch_m,
                        double position_m, double driving_force_N, CurrentVector& currents_A,
                        CurrentVector* driving_gain_N_per_A) {
  const auto coil_sets = static_cast<Eigen::Index>(estimates.size());
  currents_A.resize(2 * coil_sets);
  if (driving_gain_N_per_A != nullptr) driving_gain_N_per_A->resize(2 * coil_sets);
  double share[kMaxCoilSets];
  classical_force_share(estimates, driving_force_N, std::span<double>(share, estimates.size()));
  const double theta = electrical_angle_rad(position_m, pole_pitch_m);
  for (Eigen::Index l = 0; l < coil_sets; ++l) {
    const auto& estimate = estimates[static_cast<std::size_t>(l)];
    const double k = estimate.motor_constant_N_per_A;
    const Eigen::Vector2d sines = phase_sines(theta + estimate.phase_offset_rad);
    currents_A.segment<2>(2 * l) = share[l] / k * sines;
    if (driving_gain_N_per_A != nullptr) {
      // Row y of classical_gain: phase p's force constant (2/3)·k·sin(η + φ_p)
      // less phase c's, which is −(a + b) for the balanced set.
      driving_gain_N_per_A->segment<2>(2 * l) =
          2.0 / 3.0 * k * Eigen::Vector2d(2.0 * sines.x() + sines.y(), sines.x() + 2.0 * sines.y());
    }
  }
}

void classical_setpoints(std::span<const ClassicalEstimate> estimates, const DriveCommutation& drive,
                         double driving_force_N, PhaseConvention convention,
                         std::span<DriveSetpoint> setpoints) {
  double share[kMaxCoilSets];
  classical_force_share(estimates, driving_force_N, std::span<double>(share, estimates.size()));
  for (std::size_t l = 0; l < estimates.size(); ++l) {
    // The drive applies sin(η̂_d + Δ)·m/k̂_d; the calibrated law wants
    // sin(η̂^l)·F^{l*}/k̂^l with η̂^l = η̂_d + (ζ̂^l − ζ̂_d).
    const DriveSetpoint raw{share[l] * drive.motor_constant_N_per_A / estimates[l].motor_constant_N_per_A,
                            estimates[l].phase_offset_rad - drive.phase_offset_rad};
    setpoints[l] = transform_inverse(transform_forward(raw), convention);
  }
}

}  // namespace clm
