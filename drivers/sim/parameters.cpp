#include "drivers/sim/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

namespace clm::sim {
namespace {

[[noreturn]] void fail(const std::string& field, double value, const std::string& what) {
  std::ostringstream message;
  message.precision(17);
  message << field << " = " << value << ": " << what;
  throw ParameterError(message.str());
}

void require_finite(const std::string& field, double value) {
  if (!std::isfinite(value)) fail(field, value, "must be a finite number");
}
void require_positive(const std::string& field, double value) {
  if (!(std::isfinite(value) && value > 0.0)) fail(field, value, "must be positive");
}
void require_non_negative(const std::string& field, double value) {
  if (!(std::isfinite(value) && value >= 0.0)) fail(field, value, "must be zero or positive");
}
void require_non_negative(const std::string& field, const Wrench& value) {
  for (int q = 0; q < 3; ++q) require_non_negative(field + "[" + std::to_string(q) + "]", value[q]);
}
void require_finite(const std::string& field, const Wrench& value) {
  for (int q = 0; q < 3; ++q) require_finite(field + "[" + std::to_string(q) + "]", value[q]);
}
void validate_variation(const std::string& field, const SmoothVariation& variation) {
  require_non_negative(field + ".rms", variation.rms);
  require_positive(field + ".correlation_length_m", variation.correlation_length_m);
  require_finite(field + ".slope_per_m", variation.slope_per_m);
}

}  // namespace

void ElectromagneticParameters::validate() const {
  require_positive("pole_pitch_m", pole_pitch_m);
  require_finite("orthogonal_ratio", orthogonal_ratio);
  const int count = coil_set_count();
  if (count < 1 || count > kMaxCoilSets) {
    fail("coil_sets", count, "expected 1.." + std::to_string(kMaxCoilSets) + " coil sets");
  }
  for (int l = 0; l < count; ++l) {
    const auto& coil_set = coil_sets[static_cast<std::size_t>(l)];
    const std::string prefix = "coil_sets[" + std::to_string(l) + "].";
    require_positive(prefix + "motor_constant_N_per_A", coil_set.motor_constant_N_per_A);
    require_finite(prefix + "phase_offset_rad", coil_set.phase_offset_rad);
    require_finite(prefix + "lever_arm_m", coil_set.lever_arm_m);
    require_finite(prefix + "driving_force_lever_arm_m", coil_set.driving_force_lever_arm_m);
  }
  require_non_negative("phase_gain_mismatch_rms", phase_gain_mismatch_rms);
  // A winding with a negative gain is not a tolerance any more.
  if (phase_gain_mismatch_rms > 0.2) fail("phase_gain_mismatch_rms", phase_gain_mismatch_rms, "must be at most 0.2");
  validate_variation("magnet_intensity", magnet_intensity);
  if (magnet_intensity.rms > 0.2) fail("magnet_intensity.rms", magnet_intensity.rms, "must be at most 0.2");
  validate_variation("magnet_orientation_rad", magnet_orientation_rad);
  require_non_negative("fifth_harmonic_relative", fifth_harmonic_relative);
  require_non_negative("seventh_harmonic_relative", seventh_harmonic_relative);
  for (std::size_t n = 0; n < cogging_periodic.size(); ++n) {
    const std::string prefix = "cogging_periodic[" + std::to_string(n) + "].";
    if (cogging_periodic[n].order < 1 || cogging_periodic[n].order > 64) {
      fail(prefix + "order", cogging_periodic[n].order, "must lie in 1..64");
    }
    require_non_negative(prefix + "amplitude_N_N_Nm", cogging_periodic[n].amplitude_N_N_Nm);
  }
  require_non_negative("cogging_slow_rms_N_N_Nm", cogging_slow_rms_N_N_Nm);
  require_positive("cogging_slow_correlation_length_m", cogging_slow_correlation_length_m);
  require_finite("cogging_spring_rate_N_N_Nm_per_m", cogging_spring_rate_N_N_Nm_per_m);
  require_finite("cogging_spring_neutral_m", cogging_spring_neutral_m);
  require_finite("direction_dependent_N_N_Nm", direction_dependent_N_N_Nm);
  require_positive("direction_smoothing_velocity_m_per_s", direction_smoothing_velocity_m_per_s);
}

void MechanicsParameters::validate() const {
  require_positive("translator_mass_kg", translator_mass_kg);
  require_non_negative("viscous_friction_N_s_per_m", viscous_friction_N_s_per_m);
  require_non_negative("coulomb_friction_N", coulomb_friction_N);
  require_positive("friction_smoothing_velocity_m_per_s", friction_smoothing_velocity_m_per_s);
  require_positive("integration_step_s", integration_step_s);
  require_finite("end_stop_min_m", end_stop_min_m);
  require_finite("end_stop_max_m", end_stop_max_m);
  if (!(end_stop_max_m > end_stop_min_m)) fail("end_stop_max_m", end_stop_max_m, "must be above end_stop_min_m");
  require_non_negative("end_stop_fault_speed_m_per_s", end_stop_fault_speed_m_per_s);
  const bool none_below = limit_switch_min_m == -std::numeric_limits<double>::infinity();
  const bool none_above = limit_switch_max_m == std::numeric_limits<double>::infinity();
  if (!(none_below || (limit_switch_min_m >= end_stop_min_m && limit_switch_min_m < end_stop_max_m))) {
    fail("limit_switch_min_m", limit_switch_min_m, "must lie within the end stops (or be absent)");
  }
  if (!(none_above || (limit_switch_max_m <= end_stop_max_m && limit_switch_max_m > end_stop_min_m))) {
    fail("limit_switch_max_m", limit_switch_max_m, "must lie within the end stops (or be absent)");
  }
  if (!(limit_switch_min_m < limit_switch_max_m)) {
    fail("limit_switch_max_m", limit_switch_max_m, "must be above limit_switch_min_m");
  }
  require_non_negative("flexible_mode.frequency_Hz", flexible_mode.frequency_Hz);
  if (!(flexible_mode.damping_ratio > 0.0 && flexible_mode.damping_ratio <= 1.0)) {
    fail("flexible_mode.damping_ratio", flexible_mode.damping_ratio, "must lie in (0, 1]");
  }
  if (!(flexible_mode.encoder_mass_fraction > 0.0 && flexible_mode.encoder_mass_fraction < 1.0)) {
    fail("flexible_mode.encoder_mass_fraction", flexible_mode.encoder_mass_fraction, "must lie in (0, 1)");
  }
  // Semi-implicit Euler on the mode is stable for ω·h < 2; ω·h ≤ 0.5 keeps
  // its frequency within 1 % of the true one.
  if (2.0 * 3.141592653589793 * flexible_mode.frequency_Hz * integration_step_s > 0.5) {
    fail("flexible_mode.frequency_Hz", flexible_mode.frequency_Hz,
         "too high for integration_step_s " + std::to_string(integration_step_s) + " s: 2π·f·h must be at most 0.5");
  }
  require_non_negative("force_disturbance.rms_N", force_disturbance.rms_N);
  require_positive("force_disturbance.low_Hz", force_disturbance.low_Hz);
  if (!(force_disturbance.high_Hz >= force_disturbance.low_Hz) || !std::isfinite(force_disturbance.high_Hz)) {
    fail("force_disturbance.high_Hz", force_disturbance.high_Hz, "must be finite and at least low_Hz");
  }
}

void DriveParameters::validate() const {
  require_positive("drive.commutation.motor_constant_N_per_A", commutation.motor_constant_N_per_A);
  require_finite("drive.commutation.phase_offset_rad", commutation.phase_offset_rad);
  require_positive("phase_current_limit_A", phase_current_limit_A);
  require_positive("watchdog_timeout_s", watchdog_timeout_s);
  if (!(enable_delay_s >= 0.0 && enable_delay_s <= 1.0)) fail("enable_delay_s", enable_delay_s, "must lie in 0..1 s");
  if (!(setpoint_delay_s >= 0.0 && setpoint_delay_s <= kMaxSetpointDelay_s)) {
    fail("setpoint_delay_s", setpoint_delay_s, "must lie in 0.." + std::to_string(kMaxSetpointDelay_s) + " s");
  }
  require_non_negative("current_loop.bandwidth_Hz", current_loop.bandwidth_Hz);
  require_positive("current_loop.phase_resistance_ohm", current_loop.phase_resistance_ohm);
  require_positive("current_loop.phase_inductance_H", current_loop.phase_inductance_H);
  require_positive("current_loop.voltage_limit_V", current_loop.voltage_limit_V);
}

void SensorParameters::validate() const {
  require_non_negative("encoder_resolution_m", encoder_resolution_m);
  require_non_negative("encoder_noise_m", encoder_noise_m);
  require_non_negative("force_noise_N_N_Nm", force_noise_N_N_Nm);
  require_finite("force_bias_N_N_Nm", force_bias_N_N_Nm);
  if (!(encoder_delay_s >= 0.0 && encoder_delay_s <= kMaxEncoderDelay_s)) {
    fail("encoder_delay_s", encoder_delay_s, "must lie in 0.." + std::to_string(kMaxEncoderDelay_s) + " s");
  }
  require_positive("encoder_scale_pitch_m", encoder_scale_pitch_m);
  require_non_negative("encoder_interpolation_error_m", encoder_interpolation_error_m);
  require_non_negative("encoder_interpolation_second_m", encoder_interpolation_second_m);
  require_non_negative("encoder_power_up_offset_max_m", encoder_power_up_offset_max_m);
  require_non_negative("index_pitch_m", index_pitch_m);
  require_finite("reference_switch_min_m", reference_switch_min_m);
  require_finite("reference_switch_max_m", reference_switch_max_m);
  if (reference_switch_max_m < reference_switch_min_m) {
    fail("reference_switch_max_m", reference_switch_max_m, "must not lie below reference_switch_min_m");
  }
}

void MotorParameters::validate() const {
  electromagnetics.validate();
  mechanics.validate();
  drive.validate();
  sensors.validate();
  require_finite("stroke_min_m", stroke_min_m);
  require_finite("stroke_max_m", stroke_max_m);
  if (!(stroke_max_m > stroke_min_m)) fail("stroke_max_m", stroke_max_m, "must be above stroke_min_m");
  if (stroke_min_m < mechanics.end_stop_min_m) {
    fail("stroke_min_m", stroke_min_m, "lies beyond the lower end stop");
  }
  if (stroke_max_m > mechanics.end_stop_max_m) {
    fail("stroke_max_m", stroke_max_m, "lies beyond the upper end stop");
  }
  // The truth draws the magnet track over the end stops widened by the
  // largest lever arm each side, the slow cogging over the end stops alone,
  // each plus one correlation length of margin (ElectromagneticTruth). A
  // correlation length tiny against that travel (or a travel that overflows)
  // would need more knots than an int counts: refuse it here, by name.
  const auto& em = electromagnetics;
  double lever_reach_m = 0.0;
  for (const auto& coil_set : em.coil_sets) lever_reach_m = std::max(lever_reach_m, std::abs(coil_set.lever_arm_m));
  const double travel_m = mechanics.end_stop_max_m - mechanics.end_stop_min_m;
  const auto check_knots = [](const std::string& field, double track_m, double correlation_length_m) {
    const double knots = track_m / correlation_length_m + 2.0;
    if (!(std::ceil(knots) + 1.0 <= kMaxTrackKnots)) {  // + 1: margin for the rounding of the truth's own count
      fail(field, correlation_length_m,
           "gives " + std::to_string(knots) + " spline knots over the simulated track of " + std::to_string(track_m) +
               " m; at most " + std::to_string(static_cast<long>(kMaxTrackKnots)));
    }
  };
  if (em.magnet_intensity.rms != 0.0) {
    check_knots("magnet_intensity.correlation_length_m", travel_m + 2.0 * lever_reach_m,
                em.magnet_intensity.correlation_length_m);
  }
  if (em.magnet_orientation_rad.rms != 0.0) {
    check_knots("magnet_orientation_rad.correlation_length_m", travel_m + 2.0 * lever_reach_m,
                em.magnet_orientation_rad.correlation_length_m);
  }
  if (!em.cogging_slow_rms_N_N_Nm.isZero(0.0)) {
    check_knots("cogging_slow_correlation_length_m", travel_m, em.cogging_slow_correlation_length_m);
  }
  // The friction and the direction-dependent force are integrated explicitly;
  // their slope at zero velocity sets the stiffness of the velocity equation.
  // h·(slope)/m ≤ 0.5 keeps the substep free of overshoot (stability needs < 2).
  const double slope_N_s_per_m = mechanics.viscous_friction_N_s_per_m +
                                 mechanics.coulomb_friction_N / mechanics.friction_smoothing_velocity_m_per_s +
                                 std::abs(em.direction_dependent_N_N_Nm.x()) / em.direction_smoothing_velocity_m_per_s;
  // The friction acts on the motor's side of a flexible translator.
  const double motor_side_kg = mechanics.flexible_mode.rigid()
                                   ? mechanics.translator_mass_kg
                                   : mechanics.translator_mass_kg * (1.0 - mechanics.flexible_mode.encoder_mass_fraction);
  const double stiffness = mechanics.integration_step_s * slope_N_s_per_m / motor_side_kg;
  if (stiffness > 0.5) {
    fail("integration_step_s", mechanics.integration_step_s,
         "too large for the friction smoothing: h·(b + F_c/v_s + |C_y|/v_c)/m₁ = " + std::to_string(stiffness) +
             " > 0.5; reduce the step or widen the smoothing velocities");
  }
}

void switch_off_parasitics(ElectromagneticParameters& parameters) {
  parameters.phase_gain_mismatch_rms = 0.0;
  parameters.magnet_intensity.rms = 0.0;
  parameters.magnet_intensity.slope_per_m = 0.0;
  parameters.magnet_orientation_rad.rms = 0.0;
  parameters.magnet_orientation_rad.slope_per_m = 0.0;
  parameters.fifth_harmonic_relative = 0.0;
  parameters.seventh_harmonic_relative = 0.0;
  parameters.cogging_periodic.clear();
  parameters.cogging_slow_rms_N_N_Nm.setZero();
  parameters.cogging_spring_rate_N_N_Nm_per_m.setZero();
  parameters.direction_dependent_N_N_Nm.setZero();
  for (auto& coil_set : parameters.coil_sets) coil_set.driving_force_lever_arm_m = 0.0;
}

MotorParameters with_error_sources(MotorParameters parameters, ErrorSources kept) {
  if (!kept.force_disturbance) parameters.mechanics.force_disturbance.rms_N = 0.0;
  if (!kept.encoder) {
    SensorParameters& sensors = parameters.sensors;
    sensors.encoder_resolution_m = 0.0;
    sensors.encoder_noise_m = 0.0;
    sensors.encoder_delay_s = 0.0;
    sensors.encoder_interpolation_error_m = 0.0;
    sensors.encoder_interpolation_second_m = 0.0;
  }
  return parameters;
}

}  // namespace clm::sim
