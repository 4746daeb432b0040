#include "drivers/sim/motor_file.hpp"

#include <limits>

#include "commutation/model_file.hpp"

namespace clm::sim {
namespace {

using yaml::Node;

constexpr double kInfinity = std::numeric_limits<double>::infinity();

double optional_double(const Node& section, const char* key, double fallback, double min, double max) {
  const auto child = section.optional(key);
  return child ? child->as_double_in(min, max) : fallback;
}

double optional_positive(const Node& section, const char* key, double fallback) {
  const auto child = section.optional(key);
  return child ? child->as_positive() : fallback;
}

/// [F_y, F_x, T_z] list of three numbers, each in [min, max].
Wrench triple(const Node& node, double min, double max) {
  if (node.size() != 3) node.fail("expected [F_y, F_x, T_z], got " + std::to_string(node.size()) + " values");
  Wrench value;
  for (std::size_t q = 0; q < 3; ++q) value[static_cast<Eigen::Index>(q)] = node.at(q).as_double_in(min, max);
  return value;
}

Wrench optional_triple(const Node& section, const char* key, double min, double max) {
  const auto child = section.optional(key);
  return child ? triple(*child, min, max) : Wrench::Zero();
}

std::uint64_t seed_value(const Node& node) {
  return static_cast<std::uint64_t>(node.as_integer_in(0, std::numeric_limits<long>::max()));
}

void read_coil_sets(const Node& list, int expected, ElectromagneticParameters& em) {
  if (!list.is_sequence()) list.fail("expected a list with one entry per coil set");
  if (static_cast<int>(list.size()) != expected) {
    list.fail(std::to_string(list.size()) + " entries, motor.coil_sets says " + std::to_string(expected));
  }
  for (std::size_t l = 0; l < list.size(); ++l) {
    const Node entry = list.at(l);
    entry.expect_keys({"motor_constant_N_per_A", "phase_offset_rad", "lever_arm_m", "driving_force_lever_arm_m"});
    CoilSetParameters coil_set;
    coil_set.motor_constant_N_per_A = entry["motor_constant_N_per_A"].as_positive();
    coil_set.phase_offset_rad = entry["phase_offset_rad"].as_double_in(-2.0 * kPi, 2.0 * kPi);
    coil_set.lever_arm_m = optional_double(entry, "lever_arm_m", 0.0, -10.0, 10.0);
    coil_set.driving_force_lever_arm_m = optional_double(entry, "driving_force_lever_arm_m", 0.0, -10.0, 10.0);
    em.coil_sets.push_back(coil_set);
  }
}

void read_magnet_track(const Node& section, ElectromagneticParameters& em) {
  section.expect_keys({"intensity", "orientation", "fifth_harmonic_relative", "seventh_harmonic_relative"});
  if (const auto intensity = section.optional("intensity")) {
    intensity->expect_keys({"rms", "correlation_length_m", "slope_per_m"});
    em.magnet_intensity.rms = optional_double(*intensity, "rms", 0.0, 0.0, 0.2);
    em.magnet_intensity.correlation_length_m =
        optional_positive(*intensity, "correlation_length_m", em.magnet_intensity.correlation_length_m);
    em.magnet_intensity.slope_per_m = optional_double(*intensity, "slope_per_m", 0.0, -100.0, 100.0);
  }
  if (const auto orientation = section.optional("orientation")) {
    orientation->expect_keys({"rms_rad", "correlation_length_m", "slope_rad_per_m"});
    em.magnet_orientation_rad.rms = optional_double(*orientation, "rms_rad", 0.0, 0.0, 1.0);
    em.magnet_orientation_rad.correlation_length_m =
        optional_positive(*orientation, "correlation_length_m", em.magnet_orientation_rad.correlation_length_m);
    em.magnet_orientation_rad.slope_per_m = optional_double(*orientation, "slope_rad_per_m", 0.0, -1000.0, 1000.0);
  }
  em.fifth_harmonic_relative = optional_double(section, "fifth_harmonic_relative", 0.0, 0.0, 0.5);
  em.seventh_harmonic_relative = optional_double(section, "seventh_harmonic_relative", 0.0, 0.0, 0.5);
}

void read_cogging(const Node& section, ElectromagneticParameters& em) {
  section.expect_keys({"periodic", "slow", "spring"});
  if (const auto periodic = section.optional("periodic")) {
    if (!periodic->is_sequence()) periodic->fail("expected a list of {order, amplitude_N_N_Nm}");
    for (std::size_t n = 0; n < periodic->size(); ++n) {
      const Node entry = periodic->at(n);
      entry.expect_keys({"order", "amplitude_N_N_Nm"});
      CoggingHarmonic harmonic;
      harmonic.order = static_cast<int>(entry["order"].as_integer_in(1, 64));
      harmonic.amplitude_N_N_Nm = triple(entry["amplitude_N_N_Nm"], 0.0, kInfinity);
      em.cogging_periodic.push_back(harmonic);
    }
  }
  if (const auto slow = section.optional("slow")) {
    slow->expect_keys({"rms_N_N_Nm", "correlation_length_m"});
    em.cogging_slow_rms_N_N_Nm = optional_triple(*slow, "rms_N_N_Nm", 0.0, kInfinity);
    em.cogging_slow_correlation_length_m =
        optional_positive(*slow, "correlation_length_m", em.cogging_slow_correlation_length_m);
  }
  if (const auto spring = section.optional("spring")) {
    spring->expect_keys({"rate_N_N_Nm_per_m", "neutral_position_m"});
    em.cogging_spring_rate_N_N_Nm_per_m = optional_triple(*spring, "rate_N_N_Nm_per_m", -kInfinity, kInfinity);
    em.cogging_spring_neutral_m = optional_double(*spring, "neutral_position_m", 0.0, -kInfinity, kInfinity);
  }
}

void read_direction_dependent(const Node& section, ElectromagneticParameters& em) {
  section.expect_keys({"amplitude_N_N_Nm", "smoothing_velocity_m_per_s"});
  em.direction_dependent_N_N_Nm = optional_triple(section, "amplitude_N_N_Nm", -kInfinity, kInfinity);
  em.direction_smoothing_velocity_m_per_s =
      optional_positive(section, "smoothing_velocity_m_per_s", em.direction_smoothing_velocity_m_per_s);
}

void read_mechanics(const Node& section, const MotorParameters& motor, MechanicsParameters& mechanics) {
  section.expect_keys({"translator_mass_kg", "viscous_friction_N_s_per_m", "coulomb_friction_N",
                       "friction_smoothing_velocity_m_per_s", "integration_step_s", "end_stop_min_m",
                       "end_stop_max_m", "end_stop_fault_speed_m_per_s", "limit_switch_min_m", "limit_switch_max_m",
                       "flexible_mode",
                       "force_disturbance"});
  mechanics.translator_mass_kg = section["translator_mass_kg"].as_positive();
  mechanics.viscous_friction_N_s_per_m = optional_double(section, "viscous_friction_N_s_per_m", 0.0, 0.0, kInfinity);
  mechanics.coulomb_friction_N = optional_double(section, "coulomb_friction_N", 0.0, 0.0, kInfinity);
  mechanics.friction_smoothing_velocity_m_per_s = optional_positive(
      section, "friction_smoothing_velocity_m_per_s", mechanics.friction_smoothing_velocity_m_per_s);
  mechanics.integration_step_s = optional_double(section, "integration_step_s", mechanics.integration_step_s, 1e-7, 1e-2);
  // Hard stops default to 10 mm beyond the stroke.
  mechanics.end_stop_min_m =
      optional_double(section, "end_stop_min_m", motor.stroke_min_m - 0.01, -kInfinity, motor.stroke_min_m);
  mechanics.end_stop_max_m =
      optional_double(section, "end_stop_max_m", motor.stroke_max_m + 0.01, motor.stroke_max_m, kInfinity);
  mechanics.end_stop_fault_speed_m_per_s = optional_double(section, "end_stop_fault_speed_m_per_s", 0.0, 0.0, 10.0);
  // Without limit switches only the stops' impact is reported.
  mechanics.limit_switch_min_m = optional_double(section, "limit_switch_min_m", -kInfinity, -kInfinity, kInfinity);
  mechanics.limit_switch_max_m = optional_double(section, "limit_switch_max_m", kInfinity, -kInfinity, kInfinity);
  if (const auto mode = section.optional("flexible_mode")) {
    mode->expect_keys({"frequency_Hz", "damping_ratio", "encoder_mass_fraction"});
    auto& m = mechanics.flexible_mode;
    m.frequency_Hz = optional_double(*mode, "frequency_Hz", 0.0, 0.0, 1e5);
    m.damping_ratio = optional_double(*mode, "damping_ratio", m.damping_ratio, 1e-6, 1.0);
    m.encoder_mass_fraction = optional_double(*mode, "encoder_mass_fraction", m.encoder_mass_fraction, 1e-3, 0.999);
  }
  if (const auto disturbance = section.optional("force_disturbance")) {
    disturbance->expect_keys({"rms_N", "low_Hz", "high_Hz", "seed"});
    auto& d = mechanics.force_disturbance;
    d.rms_N = optional_double(*disturbance, "rms_N", 0.0, 0.0, 1e4);
    d.low_Hz = optional_double(*disturbance, "low_Hz", d.low_Hz, 1e-3, 1e5);
    d.high_Hz = optional_double(*disturbance, "high_Hz", d.high_Hz, d.low_Hz, 1e5);
    if (const auto seed = disturbance->optional("seed")) d.seed = seed_value(*seed);
  }
}

// The simulated drive's dynamics (the drive: section holds what a real
// drive is set to; these are its physics).
void read_drive_dynamics(const Node& section, DriveParameters& drive) {
  section.expect_keys({"setpoint_delay_s", "enable_delay_s", "current_loop"});
  drive.setpoint_delay_s = optional_double(section, "setpoint_delay_s", 0.0, 0.0, kMaxSetpointDelay_s);
  drive.enable_delay_s = optional_double(section, "enable_delay_s", 0.0, 0.0, 1.0);
  if (const auto loop = section.optional("current_loop")) {
    loop->expect_keys({"bandwidth_Hz", "phase_resistance_ohm", "phase_inductance_H", "voltage_limit_V"});
    auto& c = drive.current_loop;
    c.bandwidth_Hz = optional_double(*loop, "bandwidth_Hz", 0.0, 0.0, 1e5);
    c.phase_resistance_ohm = optional_positive(*loop, "phase_resistance_ohm", c.phase_resistance_ohm);
    c.phase_inductance_H = optional_positive(*loop, "phase_inductance_H", c.phase_inductance_H);
    c.voltage_limit_V = optional_positive(*loop, "voltage_limit_V", c.voltage_limit_V);
  }
}

void read_sensors(const Node& section, SensorParameters& sensors) {
  section.expect_keys({"noise_seed", "encoder_resolution_m", "encoder_noise_m", "force_noise_N_N_Nm",
                       "force_bias_N_N_Nm", "encoder_delay_s", "encoder_scale_pitch_m",
                       "encoder_interpolation_error_m", "encoder_interpolation_second_m",
                       "encoder_power_up_offset_max_m", "encoder_offset_seed", "index_pitch_m",
                       "reference_switch_min_m", "reference_switch_max_m"});
  if (const auto seed = section.optional("noise_seed")) sensors.noise_seed = seed_value(*seed);
  sensors.encoder_resolution_m = optional_double(section, "encoder_resolution_m", 0.0, 0.0, 1e-3);
  sensors.encoder_noise_m = optional_double(section, "encoder_noise_m", 0.0, 0.0, 1e-3);
  sensors.force_noise_N_N_Nm = optional_triple(section, "force_noise_N_N_Nm", 0.0, kInfinity);
  sensors.force_bias_N_N_Nm = optional_triple(section, "force_bias_N_N_Nm", -kInfinity, kInfinity);
  sensors.encoder_delay_s = optional_double(section, "encoder_delay_s", 0.0, 0.0, kMaxEncoderDelay_s);
  sensors.encoder_scale_pitch_m =
      optional_double(section, "encoder_scale_pitch_m", sensors.encoder_scale_pitch_m, 1e-7, 1.0);
  sensors.encoder_interpolation_error_m = optional_double(section, "encoder_interpolation_error_m", 0.0, 0.0, 1e-4);
  sensors.encoder_interpolation_second_m = optional_double(section, "encoder_interpolation_second_m", 0.0, 0.0, 1e-4);
  sensors.encoder_power_up_offset_max_m = optional_double(section, "encoder_power_up_offset_max_m", 0.0, 0.0, 1.0);
  if (const auto seed = section.optional("encoder_offset_seed")) sensors.encoder_offset_seed = seed_value(*seed);
  sensors.index_pitch_m = optional_double(section, "index_pitch_m", 0.0, 0.0, 10.0);
  sensors.reference_switch_min_m = optional_double(section, "reference_switch_min_m", 0.0, -10.0, 10.0);
  sensors.reference_switch_max_m = optional_double(section, "reference_switch_max_m", 0.0, -10.0, 10.0);
  if (sensors.reference_switch_max_m < sensors.reference_switch_min_m) {
    section.fail("reference_switch_max_m " + std::to_string(sensors.reference_switch_max_m) +
                 " m must not lie below reference_switch_min_m " + std::to_string(sensors.reference_switch_min_m) + " m");
  }
}

}  // namespace

MotorParameters read_motor_parameters(const yaml::Node& root, bool allow_other_sections) {
  root.expect_map();
  if (!allow_other_sections) root.expect_keys({"motor", "drive", "simulation"});
  const MotorDescription description = read_motor_description(root);
  const Node motor_section = root["motor"];
  motor_section.expect_keys({"pole_pitch_m", "coil_sets", "stroke_min_m", "stroke_max_m", "flexible_mode"});

  MotorParameters motor;
  motor.stroke_min_m = description.stroke_min_m;
  motor.stroke_max_m = description.stroke_max_m;

  const Node drive = root["drive"];
  drive.expect_keys({"commutation", "profile", "phase_current_limit_A", "watchdog_timeout_s", "current_loop",
                     "setpoint_delay_s", "position_delay_s"});
  motor.drive.commutation = description.drive;
  motor.drive.profile = description.drive_profile;
  motor.drive.phase_current_limit_A = optional_positive(drive, "phase_current_limit_A", motor.drive.phase_current_limit_A);
  motor.drive.watchdog_timeout_s = optional_positive(drive, "watchdog_timeout_s", motor.drive.watchdog_timeout_s);

  const Node simulation = root["simulation"];
  simulation.expect_keys({"seed", "coil_sets", "orthogonal_ratio", "phase_gain_mismatch_rms", "magnet_track",
                          "cogging", "direction_dependent", "drive", "mechanics", "sensors"});
  ElectromagneticParameters& em = motor.electromagnetics;
  em.pole_pitch_m = description.pole_pitch_m;
  if (const auto seed = simulation.optional("seed")) em.seed = seed_value(*seed);
  read_coil_sets(simulation["coil_sets"], description.coil_sets, em);
  em.orthogonal_ratio = optional_double(simulation, "orthogonal_ratio", 0.0, -10.0, 10.0);
  em.phase_gain_mismatch_rms = optional_double(simulation, "phase_gain_mismatch_rms", 0.0, 0.0, 0.2);
  if (const auto track = simulation.optional("magnet_track")) read_magnet_track(*track, em);
  if (const auto cogging = simulation.optional("cogging")) read_cogging(*cogging, em);
  if (const auto direction = simulation.optional("direction_dependent")) read_direction_dependent(*direction, em);
  if (const auto dynamics = simulation.optional("drive")) read_drive_dynamics(*dynamics, motor.drive);
  const Node mechanics = simulation["mechanics"];
  read_mechanics(mechanics, motor, motor.mechanics);
  if (const auto sensors = simulation.optional("sensors")) read_sensors(*sensors, motor.sensors);

  // What is left are the checks across keys (stroke inside the end stops,
  // integration step against the friction smoothing).
  try {
    motor.validate();
  } catch (const ParameterError& error) {
    mechanics.fail(error.what());
  }
  return motor;
}

MotorParameters load_motor_parameters(const std::string& path) {
  return read_motor_parameters(yaml::Node::load_file(path));
}

}  // namespace clm::sim
