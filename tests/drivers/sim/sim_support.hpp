#pragma once
// Shared helpers of the simulator tests: the motor files of the repository and
// motors built in code for tests that need a known, simple truth.

#include <string>
#include <vector>

#include "daemon/control/trajectory.hpp"
#include "drivers/sim/motor_file.hpp"
#include "drivers/sim/parameters.hpp"

namespace clm::sim::fixtures {

inline std::string source_path(const std::string& relative) { return std::string(CLM_SOURCE_DIR) + "/" + relative; }

inline MotorParameters default_motor() { return load_motor_parameters(source_path("config/motor-sim.yaml")); }
inline MotorParameters two_coil_motor() { return load_motor_parameters(source_path("config/motor-sim-2coil.yaml")); }

/// An L-coil-set motor without parasitics, friction or sensor noise, built in
/// code: k^l = 60 + l N/A, ζ^l = −0.5 + 0.02·l rad, d^l spread over ±0.06 m.
inline MotorParameters ideal_motor(int coil_sets, double pole_pitch_m = 0.032) {
  MotorParameters motor;
  motor.stroke_min_m = -0.1;
  motor.stroke_max_m = 0.1;
  auto& em = motor.electromagnetics;
  em.pole_pitch_m = pole_pitch_m;
  em.orthogonal_ratio = 0.12;
  for (int l = 0; l < coil_sets; ++l) {
    const double lever = coil_sets == 1 ? 0.01 : -0.06 + 0.12 * l / (coil_sets - 1);
    em.coil_sets.push_back({60.0 + l, -0.5 + 0.02 * l, lever, 0.0});
  }
  motor.mechanics.translator_mass_kg = 12.0;
  motor.mechanics.end_stop_min_m = -0.11;
  motor.mechanics.end_stop_max_m = 0.11;
  motor.drive.commutation = {67.0, -0.52};
  motor.drive.phase_current_limit_A = 20.0;
  motor.drive.watchdog_timeout_s = 0.005;
  return motor;
}

/// Switches off the sensor noise and bias and the encoder quantisation.
inline void ideal_sensors(MotorParameters& motor) {
  motor.sensors.encoder_resolution_m = 0.0;
  motor.sensors.encoder_noise_m = 0.0;
  motor.sensors.force_noise_N_N_Nm.setZero();
  motor.sensors.force_bias_N_N_Nm.setZero();
}

/// A back-and-forth over 80 % of the motor's stroke with the Fig. 8 limits at
/// `velocity_m_per_s` (the Fig. 8 reference itself assumes ±0.1 m of stroke).
inline control::MoveProgram stroke_program(const MotorParameters& motor, double velocity_m_per_s) {
  const double margin = 0.1 * (motor.stroke_max_m - motor.stroke_min_m);
  const auto limits = control::fig8_limits(velocity_m_per_s);
  return control::MoveProgram(motor.stroke_min_m + margin, {{motor.stroke_max_m - margin, limits, 0.25},
                                                            {motor.stroke_min_m + margin, limits, 0.25}});
}

/// The Fig. 8 reference scaled to 80 % of the motor's stroke: three
/// back-and-forths at 0.025, 0.075 and 0.15 m/s with 0.25 s dwells.
inline control::MoveProgram stroke_fig8_program(const MotorParameters& motor) {
  const double margin = 0.1 * (motor.stroke_max_m - motor.stroke_min_m);
  std::vector<control::ProgramStep> steps;
  for (const double velocity : {0.025, 0.075, 0.15}) {
    const auto limits = control::fig8_limits(velocity);
    steps.push_back({motor.stroke_max_m - margin, limits, 0.25});
    steps.push_back({motor.stroke_min_m + margin, limits, 0.25});
  }
  return control::MoveProgram(motor.stroke_min_m + margin, std::move(steps));
}

}  // namespace clm::sim::fixtures
