#include "daemon/servod/servod_config.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <optional>
#include <stdexcept>
#include <tuple>

#include "config/command_key.hpp"
#include "config/sha256.hpp"
#include "daemon/control/position_controller.hpp"
#include "drivers/can/can_protocol.hpp"
#include "daemon/servod/feedforward_file.hpp"
#include "daemon/servod/file_policy.hpp"
#include "daemon/servod/parameters.hpp"

namespace clm::servod {
namespace {

/// A run-time parameter read with its range (parameters.hpp), capped at `max` too.
double in_range(const yaml::Node& node, const char* key, double max = std::numeric_limits<double>::infinity()) {
  const RuntimeParameter* parameter = find_runtime_parameter(key);
  return node.as_double_in(parameter->min, std::min(parameter->max, max));
}

std::string resolve(const std::string& directory, const std::string& path) {
  if (path.empty()) return path;
  const std::filesystem::path p(path);
  return p.is_absolute() ? path : (std::filesystem::path(directory) / p).lexically_normal().string();
}

servo::CommutationMode parse_mode(const yaml::Node& node) {
  const std::string text = node.as_string();
  if (text == "original") return servo::CommutationMode::kOriginal;
  if (text == "classical") return servo::CommutationMode::kClassical;
  if (text == "pgnn") return servo::CommutationMode::kPgnn;
  if (text == "spline") return servo::CommutationMode::kSpline;
  if (text == "oracle") return servo::CommutationMode::kOracle;
  node.fail("expected original, classical, pgnn, spline or oracle, got '" + text + "'");
}

std::string optional_path(const yaml::Node& section, const char* key, const std::string& directory) {
  const auto node = section.optional(key);
  return node ? resolve(directory, node->as_string()) : std::string();
}

/// Fails at `node` unless `path` exists. The error_code overload: the
/// throwing one lets std::filesystem_error ("File name too long", found by
/// fuzz_servod_config, docs/fuzzing.md) escape without the config's line.
void require_existing(const yaml::Node& node, const std::string& path) {
  std::error_code error;
  const bool exists = std::filesystem::exists(path, error);
  if (error) node.fail("file '" + path + "': " + error.message());
  if (!exists) node.fail("file '" + path + "' does not exist");
}

void require_file(const yaml::Node& section, const char* key, const std::string& path) {
  if (!path.empty()) require_existing(section[key], path);
}

bool valid_axis_name(const std::string& name) {
  if (name.empty() || name.size() > 32) return false;
  for (const char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '.' || c == '-';
    if (!ok) return false;
  }
  return true;
}

/// The canonical absolute path of an existing directory; fails at `node`.
std::string canonical_directory(const yaml::Node& node, const std::string& path) {
  std::error_code error;
  const auto canonical = std::filesystem::canonical(path, error);
  if (error) node.fail("directory '" + path + "': " + error.message());
  if (!std::filesystem::is_directory(canonical, error)) node.fail("'" + path + "' is not a directory");
  return canonical.string();
}

}  // namespace

ServodConfig parse_servod_config(const yaml::Node& root, const std::string& directory) {
  root.expect_keys({"motor_file", "axis", "loop", "can", "control", "commutation", "faults", "telemetry", "commands",
                    "motion", "homing"});
  ServodConfig config;
  config.origin = root.file();
  if (const auto axis = root.optional("axis")) {
    axis->expect_keys({"name"});
    if (const auto v = axis->optional("name")) {
      config.axis_name = v->as_string();
      if (!valid_axis_name(config.axis_name)) v->fail("axis name must have 1..32 characters of A-Z a-z 0-9 _ . -");
    }
  }
  config.motor_file = resolve(directory, root["motor_file"].as_string());
  require_existing(root["motor_file"], config.motor_file);
  config.motor = load_motor_description(config.motor_file);
  config.motor_sha256 = sha256_file(config.motor_file);

  if (const auto loop = root.optional("loop")) {
    loop->expect_keys({"rate_hz", "clock", "priority", "cpu", "lock_memory", "require_realtime",
                       "receive_window_fraction"});
    if (const auto v = loop->optional("rate_hz")) config.loop.rate_hz = v->as_double_in(10.0, 20000.0);
    if (const auto v = loop->optional("clock")) {
      const std::string clock = v->as_string();
      if (clock == "realtime") {
        config.loop.clock = ClockMode::kRealtime;
      } else if (clock == "virtual") {
        config.loop.clock = ClockMode::kVirtual;
      } else {
        v->fail("expected realtime or virtual, got '" + clock + "'");
      }
    }
    if (const auto v = loop->optional("priority")) config.loop.priority = static_cast<int>(v->as_integer_in(0, 99));
    if (const auto v = loop->optional("cpu")) config.loop.cpu = static_cast<int>(v->as_integer_in(-1, 1023));
    if (const auto v = loop->optional("lock_memory")) config.loop.lock_memory = v->as_bool();
    if (const auto v = loop->optional("require_realtime")) config.loop.require_realtime = v->as_bool();
    if (const auto v = loop->optional("receive_window_fraction")) config.loop.receive_window_fraction = v->as_double_in(0.05, 0.9);
  }
  config.servo.period_s = 1.0 / config.loop.rate_hz;
  config.servo.pole_pitch_m = config.motor.pole_pitch_m;
  config.servo.drive = config.motor.drive;
  config.servo.current_loop = config.motor.current_loop;  // drive.current_loop of the motor file
  config.servo.setpoint_delay_s = config.motor.setpoint_delay_s;
  config.servo.protocol.coil_sets = config.motor.coil_sets;
  config.servo.protocol.drive_profile = config.motor.drive_profile;  // drive.profile of the motor file

  // No force_sensor_node_id: the axis has no force sensor (docs/servod.md, "Service without a force sensor").
  config.servo.protocol.force_sensor_node_id = can::kNoForceSensor;
  if (const auto can = root.optional("can")) {
    can->expect_keys({"interface", "bitrate_bps", "drive_node_id", "force_sensor_node_id", "bus_load_limit",
                      "sim_fault_plan"});
    if (const auto v = can->optional("interface")) {
      config.can.interface = v->as_string();
      if (config.can.interface.empty() || config.can.interface.size() > 15) v->fail("interface name must have 1..15 characters");
      config.can.bus = config.can.interface == kSimulatedInterface ? BusKind::kSimulated : BusKind::kSocketCan;
    }
    if (const auto v = can->optional("bitrate_bps")) config.can.bitrate_bps = v->as_double_in(10e3, 1e6);
    if (const auto v = can->optional("drive_node_id")) config.servo.protocol.drive_node_id = static_cast<std::uint8_t>(v->as_integer_in(1, 127));
    if (const auto v = can->optional("force_sensor_node_id")) config.servo.protocol.force_sensor_node_id = static_cast<std::uint8_t>(v->as_integer_in(1, 127));
    if (const auto v = can->optional("bus_load_limit")) config.can.bus_load_limit = v->as_double_in(0.01, 0.7);
    if (const auto v = can->optional("sim_fault_plan")) {
      if (config.can.bus != BusKind::kSimulated) v->fail("fault injection needs the embedded simulated motor (interface: sim)");
      try {
        config.can.sim_fault_plan = sim::parse_planned_faults(v->as_string());
      } catch (const std::invalid_argument& e) {
        v->fail(e.what());
      }
    }
  }
  try {
    config.servo.protocol.validate();
  } catch (const std::invalid_argument& e) {
    root["motor_file"].fail(std::string("motor does not fit the CAN protocol: ") + e.what());
  }
  // The schedule must fit a real bus. The in-process simulated bus has no
  // bitrate, so there the load is only computed (faster loops can be studied).
  config.can.bus_load = can::bus_load(config.servo.protocol, config.can.bitrate_bps, config.loop.rate_hz);
  if (config.can.bus != BusKind::kSimulated) {
    try {
      can::check_bus_load(config.servo.protocol, config.can.bitrate_bps, config.loop.rate_hz, config.can.bus_load_limit);
    } catch (const std::invalid_argument& e) {
      const auto rate = root.has("loop") ? root["loop"].optional("rate_hz") : std::nullopt;
      (rate ? *rate : root.has("can") ? root["can"] : root["motor_file"]).fail(e.what());
    }
  }

  double mass_kg = 0.0;
  if (const auto control = root.optional("control")) {
    control->expect_keys({"bandwidth_hz", "mass_kg", "feedforward", "feedforward_file", "soft_limit_min_m",
                          "soft_limit_max_m", "following_error_limit_m", "force_limit_N", "saturation_time_limit_s",
                          "standstill_velocity_m_per_s"});
    if (const auto v = control->optional("bandwidth_hz")) config.control_bandwidth_hz = in_range(*v, "control.bandwidth_hz", config.loop.rate_hz / 6.0);
    mass_kg = (*control)["mass_kg"].as_positive();
    if (const auto ff = control->optional("feedforward")) {
      ff->expect_keys({"mass_kg", "viscous_N_s_per_m", "coulomb_N"});
      if (const auto v = ff->optional("mass_kg")) config.servo.feedforward.mass_kg = in_range(*v, "control.feedforward.mass_kg");
      if (const auto v = ff->optional("viscous_N_s_per_m")) config.servo.feedforward.viscous_N_s_per_m = in_range(*v, "control.feedforward.viscous_N_s_per_m");
      if (const auto v = ff->optional("coulomb_N")) config.servo.feedforward.coulomb_N = in_range(*v, "control.feedforward.coulomb_N");
    }
    config.feedforward_file = optional_path(*control, "feedforward_file", directory);
    require_file(*control, "feedforward_file", config.feedforward_file);
    if (!config.feedforward_file.empty()) {
      if (control->has("feedforward")) (*control)["feedforward_file"].fail("give feedforward or feedforward_file, not both");
    }
    if (const auto v = control->optional("following_error_limit_m")) config.servo.following_error_limit_m = in_range(*v, "control.following_error_limit_m");
    // Default soft limits: the stroke, inset by twice the following-error
    // limit (relation 5 of the safe envelope, control::check_envelope).
    const double inset_m = 2.0 * config.servo.following_error_limit_m;
    config.servo.soft_limit_min_m = config.motor.stroke_min_m + inset_m;
    config.servo.soft_limit_max_m = config.motor.stroke_max_m - inset_m;
    if (const auto v = control->optional("soft_limit_min_m")) config.servo.soft_limit_min_m = v->as_double();
    if (const auto v = control->optional("soft_limit_max_m")) config.servo.soft_limit_max_m = v->as_double();
    if (!(config.servo.soft_limit_max_m > config.servo.soft_limit_min_m)) {
      (*control)["soft_limit_max_m"].fail("must be above soft_limit_min_m");
    }
    if (const auto v = control->optional("force_limit_N")) config.servo.force_limit_N = in_range(*v, "control.force_limit_N");
    if (const auto v = control->optional("saturation_time_limit_s")) config.servo.saturation_time_limit_s = in_range(*v, "control.saturation_time_limit_s");
    if (const auto v = control->optional("standstill_velocity_m_per_s")) config.servo.standstill_velocity_m_per_s = v->as_double_in(1e-6, 1.0);
  } else {
    root["control"];  // throws "missing key 'control'": mass_kg has no default
  }
  config.control_mass_kg = mass_kg;
  config.servo.machine = {mass_kg, config.motor.stroke_min_m, config.motor.stroke_max_m};
  try {
    config.servo.pid = control::tune_pid(mass_kg, config.control_bandwidth_hz);
  } catch (const std::invalid_argument&) {
    // Each value passed its own check; together they overflow the gains (k_p ∝ m ω_c², k_i ∝ m ω_c³).
    const yaml::Node mass_node = root["control"]["mass_kg"];
    char bandwidth[32];
    std::snprintf(bandwidth, sizeof bandwidth, "%g", config.control_bandwidth_hz);
    mass_node.fail("value " + mass_node.scalar_text() + " kg gives non-finite PID gains at control.bandwidth_hz " +
                   bandwidth + " Hz (k_p grows with mass_kg * bandwidth_hz^2, k_i with mass_kg * bandwidth_hz^3)");
  }
  config.plant = control::described_plant(config.motor, mass_kg);
  if (const std::string shortfall = control::margin_shortfall(config.servo.pid, config.servo.period_s, config.plant);
      !shortfall.empty()) {
    const auto bandwidth = root["control"].optional("bandwidth_hz");
    (bandwidth ? *bandwidth : root["control"])
        .fail("the position loop tuned for " + yaml::format_double(config.control_bandwidth_hz) + " Hz is " + shortfall +
              " on the plant " + config.motor_file +
              " describes (motor.flexible_mode, drive.current_loop, drive.setpoint_delay_s + position_delay_s)");
  }

  if (const auto commutation = root.optional("commutation")) {
    commutation->expect_keys({"mode", "calibration_file", "pgnn_model_file", "spline_model_file", "power",
                              "phase_convention", "min_singular_value_ratio"});
    if (const auto v = commutation->optional("mode")) config.commutation.mode = parse_mode(*v);
    config.commutation.calibration_file = optional_path(*commutation, "calibration_file", directory);
    config.commutation.pgnn_model_file = optional_path(*commutation, "pgnn_model_file", directory);
    config.commutation.spline_model_file = optional_path(*commutation, "spline_model_file", directory);
    require_file(*commutation, "calibration_file", config.commutation.calibration_file);
    require_file(*commutation, "pgnn_model_file", config.commutation.pgnn_model_file);
    require_file(*commutation, "spline_model_file", config.commutation.spline_model_file);
    if (const auto v = commutation->optional("power")) {
      const std::string power = v->as_string();
      if (power == "true") {
        config.commutation.options.power_metric = PowerMetric::kTruePower;
      } else if (power == "paper") {
        config.commutation.options.power_metric = PowerMetric::kCurrentNorm;
      } else {
        v->fail("expected true or paper, got '" + power + "'");
      }
    }
    if (const auto v = commutation->optional("phase_convention")) {
      const std::string convention = v->as_string();
      if (convention == "signed_magnitude") {
        config.commutation.options.phase_convention = PhaseConvention::kSignedMagnitude;
      } else if (convention == "nonnegative_magnitude") {
        config.commutation.options.phase_convention = PhaseConvention::kNonNegativeMagnitude;
      } else {
        v->fail("expected signed_magnitude or nonnegative_magnitude, got '" + convention + "'");
      }
    }
    if (const auto v = commutation->optional("min_singular_value_ratio")) {
      config.commutation.options.min_singular_value_ratio = v->as_double_in(0.0, 0.5);
    }
    config.servo.phase_convention = config.commutation.options.phase_convention;
    const auto needs = [&](servo::CommutationMode mode, const std::string& file, const char* key) {
      if (config.commutation.mode == mode && file.empty()) {
        (*commutation)["mode"].fail(std::string("mode needs commutation.") + key);
      }
    };
    needs(servo::CommutationMode::kClassical, config.commutation.calibration_file, "calibration_file");
    needs(servo::CommutationMode::kPgnn, config.commutation.pgnn_model_file, "pgnn_model_file");
    needs(servo::CommutationMode::kSpline, config.commutation.spline_model_file, "spline_model_file");
    if (config.commutation.mode == servo::CommutationMode::kOracle && config.can.bus != BusKind::kSimulated) {
      (*commutation)["mode"].fail("the oracle commutation exists only with can.interface: sim");
    }
  }

  if (const auto motion = root.optional("motion")) {
    motion->expect_keys({"velocity_m_per_s", "acceleration_m_per_s2", "jerk_m_per_s3", "stop_deceleration_m_per_s2",
                         "stop_jerk_m_per_s3", "quick_stop_deceleration_m_per_s2", "quick_stop_jerk_m_per_s3",
                         "recovery_velocity_fraction", "recovery_margin_m", "jog_timeout_s"});
    auto& limits = config.servo.motion_limits;
    if (const auto v = motion->optional("velocity_m_per_s")) limits.velocity_m_per_s = in_range(*v, "motion.velocity_m_per_s");
    if (const auto v = motion->optional("acceleration_m_per_s2")) limits.acceleration_m_per_s2 = in_range(*v, "motion.acceleration_m_per_s2");
    if (const auto v = motion->optional("jerk_m_per_s3")) limits.jerk_m_per_s3 = in_range(*v, "motion.jerk_m_per_s3");
    // The stop limits default to the move limits, the quick stop's to the stop's.
    auto& stop = config.servo.stop_limits;
    stop = {limits.acceleration_m_per_s2, limits.jerk_m_per_s3};
    if (const auto v = motion->optional("stop_deceleration_m_per_s2")) stop.deceleration_m_per_s2 = in_range(*v, "motion.stop_deceleration_m_per_s2");
    if (const auto v = motion->optional("stop_jerk_m_per_s3")) stop.jerk_m_per_s3 = in_range(*v, "motion.stop_jerk_m_per_s3");
    auto& quick = config.servo.quick_stop_limits;
    quick = stop;
    if (const auto v = motion->optional("quick_stop_deceleration_m_per_s2")) {
      quick.deceleration_m_per_s2 = in_range(*v, "motion.quick_stop_deceleration_m_per_s2");
      if (quick.deceleration_m_per_s2 < stop.deceleration_m_per_s2) {
        v->fail("must not be below the stop deceleration " + std::to_string(stop.deceleration_m_per_s2) + " m/s^2");
      }
    }
    if (const auto v = motion->optional("quick_stop_jerk_m_per_s3")) {
      quick.jerk_m_per_s3 = in_range(*v, "motion.quick_stop_jerk_m_per_s3");
      if (quick.jerk_m_per_s3 < stop.jerk_m_per_s3) {
        v->fail("must not be below the stop jerk " + std::to_string(stop.jerk_m_per_s3) + " m/s^3");
      }
    }
    if (const auto v = motion->optional("recovery_velocity_fraction")) config.servo.recovery_velocity_fraction = v->as_double_in(0.001, 1.0);
    if (const auto v = motion->optional("recovery_margin_m")) config.servo.recovery_margin_m = v->as_double_in(0.0, 1.0);
    if (const auto v = motion->optional("jog_timeout_s")) config.servo.jog_timeout_s = v->as_double_in(0.01, 10.0);
  }

  if (const auto homing = root.optional("homing")) {
    homing->expect_keys({"method", "direction", "search_velocity_m_per_s", "search_distance_m", "reference_position_m",
                         "index_in_switch", "hard_stop_force_N", "hard_stop_following_error_m", "back_off_m",
                         "commutation_finding"});
    auto& h = config.servo.homing;
    if (const auto v = homing->optional("method")) {
      const std::string method = v->as_string();
      const auto found = std::find(kReferenceMethods.begin(), kReferenceMethods.end(), method);
      if (found == kReferenceMethods.end()) v->fail("expected none, index, reference_switch or hard_stop, got '" + method + "'");
      h.method = static_cast<control::HomingMethod>(found - kReferenceMethods.begin());
    }
    if (const auto v = homing->optional("direction")) {
      h.direction = static_cast<int>(v->as_integer_in(-1, 1));
      if (h.direction == 0) v->fail("expected 1 (towards soft_limit_max_m) or -1, got 0");
    }
    if (const auto v = homing->optional("search_velocity_m_per_s")) h.search_velocity_m_per_s = v->as_double_in(1e-5, 0.1);
    if (const auto v = homing->optional("search_distance_m")) h.search_distance_m = v->as_double_in(1e-4, 10.0);
    if (const auto v = homing->optional("reference_position_m")) h.reference_position_m = v->as_double_in(-10.0, 10.0);
    if (const auto v = homing->optional("hard_stop_force_N")) h.hard_stop_force_N = v->as_double_in(0.1, 10000.0);
    if (const auto v = homing->optional("hard_stop_following_error_m")) {
      h.hard_stop_following_error_m = v->as_double_in(1e-6, 0.01);
    }
    if (const auto v = homing->optional("back_off_m")) h.back_off_m = v->as_double_in(1e-5, 0.1);
    if (const auto v = homing->optional("index_in_switch")) {
      h.index_in_switch = v->as_bool();
      if (h.index_in_switch && h.method != control::HomingMethod::kReferenceSwitch) {
        v->fail("index_in_switch: true needs method: reference_switch");
      }
    }
    if (const auto finding = homing->optional("commutation_finding")) {
      finding->expect_keys({"force_N", "max_motion_m", "settle_s", "phases", "attempts"});
      auto& f = h.finding;
      if (const auto v = finding->optional("force_N")) f.force_N = v->as_double_in(0.1, 1000.0);
      if (const auto v = finding->optional("max_motion_m")) f.max_motion_m = v->as_double_in(1e-5, 0.05);
      if (const auto v = finding->optional("settle_s")) f.settle_s = v->as_double_in(0.005, 2.0);
      if (const auto v = finding->optional("phases")) {
        f.phases = static_cast<int>(v->as_integer_in(8, control::kMaxFindingPhases));
        if (f.phases % 2 != 0) v->fail("expected an even number of phases, got " + std::to_string(f.phases));
      }
      if (const auto v = finding->optional("attempts")) f.attempts = static_cast<int>(v->as_integer_in(1, 10));
    }
  }

  if (const auto faults = root.optional("faults")) {
    faults->expect_keys(
        {"missing_frame_limit", "overrun_limit", "stall_limit_s", "enable_timeout_s", "current_limited_limit_s"});
    if (const auto v = faults->optional("stall_limit_s")) config.servo.stall_limit_s = v->as_double_in(2.0 / config.loop.rate_hz, 10.0);
    if (const auto v = faults->optional("enable_timeout_s")) {
      config.servo.enable_timeout_s = v->as_double_in(2.0 / config.loop.rate_hz, 10.0);
    }
    if (const auto v = faults->optional("current_limited_limit_s")) {
      config.servo.current_limited_limit_s = v->as_double_in(1.0 / config.loop.rate_hz, 10.0);
    }
    if (const auto v = faults->optional("missing_frame_limit")) config.servo.missing_frame_limit = static_cast<int>(v->as_integer_in(1, 1000));
    if (const auto v = faults->optional("overrun_limit")) config.servo.overrun_limit = static_cast<int>(v->as_integer_in(1, 1000));
  }
  if (const auto telemetry = root.optional("telemetry")) {
    telemetry->expect_keys({"enabled", "lcm_url", "allow_network", "state_decimation", "status_rate_hz"});
    if (const auto v = telemetry->optional("allow_network")) config.telemetry.allow_network = v->as_bool();
    if (const auto v = telemetry->optional("enabled")) config.telemetry.enabled = v->as_bool();
    if (const auto v = telemetry->optional("lcm_url")) config.telemetry.lcm_url = v->as_string();
    if (const auto v = telemetry->optional("state_decimation")) config.telemetry.state_decimation = static_cast<int>(v->as_integer_in(1, 100000));
    if (const auto v = telemetry->optional("status_rate_hz")) config.telemetry.status_rate_hz = v->as_double_in(0.1, 100.0);
  }
  if (config.telemetry.enabled) {
    const std::optional<yaml::Node> telemetry_node = root.optional("telemetry");
    const std::optional<yaml::Node> url_key = telemetry_node ? telemetry_node->optional("lcm_url") : std::nullopt;
    const yaml::Node* url_node = url_key ? &*url_key : nullptr;
    int ttl = 0;
    try {
      ttl = lcm_url_ttl(config.telemetry.lcm_url);
    } catch (const std::invalid_argument& e) {
      (url_node ? *url_node : root).fail(e.what());
    }
    if (ttl > 0 && !config.telemetry.allow_network) {
      (url_node ? *url_node : root)
          .fail("ttl=" + std::to_string(ttl) +
                " sends states and takes commands beyond this host; set telemetry.allow_network: true to accept that "
                "(docs/telemetry.md)");
    }
  }

  config.commands.file_directories = {canonical_directory(root, directory)};
  config.commands.key_file = default_command_key_path();
  if (const auto commands = root.optional("commands")) {
    commands->expect_keys({"max_age_s", "control_lease_s", "deadman_timeout_s", "file_directories", "max_file_bytes", "key_file"});
    if (const auto v = commands->optional("key_file")) config.commands.key_file = resolve(directory, v->as_string());
    if (const auto v = commands->optional("max_age_s")) config.commands.max_age_s = v->as_double_in(0.01, 3600.0);
    if (const auto v = commands->optional("control_lease_s")) config.commands.control_lease_s = v->as_double_in(0.1, 86400.0);
    if (const auto v = commands->optional("deadman_timeout_s")) {
      config.commands.deadman_timeout_s = v->as_double_in(0.5, 10.0);
    }
    if (const auto v = commands->optional("max_file_bytes")) config.commands.max_file_bytes = v->as_integer_in(1024, 1L << 30);
    if (const auto v = commands->optional("file_directories")) {
      config.commands.file_directories.clear();
      if (!v->is_sequence()) v->fail("expected a list of directories");
      for (std::size_t i = 0; i < v->size(); ++i) {
        const yaml::Node entry = v->at(i);
        config.commands.file_directories.push_back(canonical_directory(entry, resolve(directory, entry.as_string())));
      }
      if (config.commands.file_directories.empty()) v->fail("list at least one directory");
    }
  }
  // The files the configuration names obey the policy of the files commands
  // name (docs/servod.md, "Files"): a configuration written from what a
  // command or a tool claimed cannot reach beyond it.
  const FilePolicy policy{config.commands.file_directories, config.commands.max_file_bytes};
  for (const auto& [section, key, path] :
       {std::tuple{"commutation", "calibration_file", &config.commutation.calibration_file},
        std::tuple{"commutation", "pgnn_model_file", &config.commutation.pgnn_model_file},
        std::tuple{"commutation", "spline_model_file", &config.commutation.spline_model_file},
        std::tuple{"control", "feedforward_file", &config.feedforward_file}}) {
    if (path->empty()) continue;
    std::string canonical;
    if (const std::string refusal = check_loadable(policy, *path, canonical); !refusal.empty()) {
      root[section][key].fail(refusal);
    }
    *path = canonical;
  }
  // Read once it is known to be allowed.
  if (!config.feedforward_file.empty()) config.servo.feedforward = load_feedforward_file(config.feedforward_file).parameters;

  try {
    config.servo.validate();
  } catch (const std::invalid_argument& e) {
    root.fail(e.what());
  }
  return config;
}

int lcm_url_ttl(const std::string& url) {
  if (url.rfind("udpm://", 0) != 0) return -1;
  const auto query = url.find('?');
  if (query == std::string::npos) return 0;
  std::size_t pos = query + 1;
  while (pos <= url.size()) {
    const std::size_t end = std::min(url.find('&', pos), url.size());
    const std::string option = url.substr(pos, end - pos);
    if (option.rfind("ttl=", 0) == 0) {
      const std::string value = option.substr(4);
      if (value.empty() || value.size() > 3 || value.find_first_not_of("0123456789") != std::string::npos ||
          std::stoi(value) > 255) {
        throw std::invalid_argument("ttl must be a whole number 0..255, got '" + value + "'");
      }
      return std::stoi(value);
    }
    pos = end + 1;
  }
  return 0;
}

ServodConfig load_servod_config(const std::string& path) {
  const std::string text = yaml::Node::read_file(path);
  const auto root = yaml::Node::load_string(text, path);
  const std::string directory = std::filesystem::path(path).parent_path().string();
  ServodConfig config = parse_servod_config(root, directory.empty() ? "." : directory);
  config.origin_sha256 = sha256_hex(text);
  return config;
}

LawLimits law_limits(const ServodConfig& config) {
  return {config.loop.rate_hz, config.motor.drive.motor_constant_N_per_A, config.motor.stroke_min_m,
          config.motor.stroke_max_m};
}

EncoderReference encoder_reference(const ServodConfig& config) {
  return {control::name(config.servo.homing.method), config.servo.homing.reference_position_m};
}

}  // namespace clm::servod
