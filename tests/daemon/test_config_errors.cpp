// Configurations with errors are refused before anything runs, with one line
// naming the file, the line and the key path (style rules 4 and 8). Each case
// changes one line of a small valid configuration written to a temporary
// directory; the line numbers below are those of that text.
#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "daemon/control/stop_profile.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "daemon/servod/servod_config.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;

namespace {

/// A valid configuration, one key per line; `lines[k]` is line k + 1.
std::vector<std::string> valid_lines() {
  return {
      "motor_file: " + test::absolute_encoder_file("motor-sim.yaml"),  // 1
      "loop:",                                                       // 2
      "  rate_hz: 1000",                                             // 3
      "  clock: virtual",                                            // 4
      "can:",                                                        // 5
      "  interface: sim",                                            // 6
      "  bitrate_bps: 1000000",                                      // 7
      "control:",                                                    // 8
      "  mass_kg: 15.0",                                             // 9
      "  bandwidth_hz: 40.0",                                        // 10
      "commutation:",                                                // 11
      "  mode: original",                                            // 12
      "faults:",                                                     // 13
      "  missing_frame_limit: 3",                                    // 14
      "telemetry:",                                                  // 15
      "  enabled: false",                                            // 16
  };
}

std::string join(const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& line : lines) text += line + "\n";
  return text;
}

/// Writes the lines as servod.yaml and returns the loader's message ("" if it loaded).
std::string load_error(const test::TemporaryDirectory& dir, const std::vector<std::string>& lines) {
  const std::string path = dir.file("servod.yaml");
  test::write_text(path, join(lines));
  try {
    (void)servod::load_servod_config(path);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("the valid test configuration loads and runs", "[daemon][config]") {
  test::TemporaryDirectory dir("clm-servod-config");
  REQUIRE(load_error(dir, valid_lines()).empty());
  const servod::ServodConfig config = servod::load_servod_config(dir.file("servod.yaml"));
  CHECK(config.can.bus == servod::BusKind::kSimulated);  // interface: sim
  servod::WiredAxis axis(config);
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(10);
  CHECK(daemon.cycle().status().state == servo::ServoState::kDisabled);
}

TEST_CASE("the real-axis template loads, needs real-time rights, and stops inside the end stops from its limits",
          "[daemon][config]") {
  // config/servod-real.yaml (docs/bring-up.md): loading reads it and its
  // motor file, not the bus.
  const auto config = servod::load_servod_config(test::source_path("config/servod-real.yaml"));
  CHECK(config.can.interface == "can0");
  CHECK(config.can.bus == servod::BusKind::kSocketCan);
  CHECK(config.loop.require_realtime);
  CHECK(config.motor.stroke_min_m < config.servo.soft_limit_min_m);
  CHECK(config.servo.soft_limit_max_m < config.motor.stroke_max_m);
  // The worst case the limits allow: at a soft limit, outward at the largest
  // velocity and acceleration, then a quick stop (a fault reaction).
  const auto& m = config.servo.motion_limits;
  for (const double direction : {1.0, -1.0}) {
    const double limit_m = direction > 0 ? config.servo.soft_limit_max_m : config.servo.soft_limit_min_m;
    const auto stop = control::StopProfile::plan(
        {limit_m, direction * m.velocity_m_per_s, direction * m.acceleration_m_per_s2, 0.0},
        config.servo.quick_stop_limits);
    REQUIRE(stop.valid());
    INFO("quick stop from the soft limit " << limit_m << " m rests at " << stop.rest_position_m() << " m");
    if (direction > 0) CHECK(stop.rest_position_m() < config.motor.stroke_max_m);
    if (direction < 0) CHECK(stop.rest_position_m() > config.motor.stroke_min_m);
  }
}

TEST_CASE("configuration errors are refused naming file, line and key path", "[daemon][config]") {
  test::TemporaryDirectory dir("clm-servod-config");
  const std::string file = dir.file("servod.yaml");
  auto lines = valid_lines();

  SECTION("unknown key") {
    lines.insert(lines.begin() + 10, "  gain_N_per_m: 5.0");  // becomes line 11
    CHECK(load_error(dir, lines) == file + ":11: control.gain_N_per_m: unknown key 'gain_N_per_m'");
  }
  SECTION("unknown section") {
    lines.push_back("logging: {level: debug}");
    CHECK(load_error(dir, lines) == file + ":17: logging: unknown key 'logging'");
  }
  SECTION("a misspelt key gets the nearest known key") {
    lines.push_back("telemetri: {enabled: false}");
    CHECK(load_error(dir, lines) == file + ":17: telemetri: unknown key 'telemetri'; did you mean 'telemetry'?");
    lines.pop_back();
    lines[13] = "  overun_limit: 5";
    CHECK(load_error(dir, lines) == file + ":14: faults.overun_limit: unknown key 'overun_limit'; did you mean "
                                           "'overrun_limit'?");
  }
  SECTION("a key given twice") {
    lines.push_back("faults: {overrun_limit: 1000}");
    CHECK(load_error(dir, lines) == file + ":17: faults: given twice (first on line 13)");
  }
  SECTION("wrong type") {
    lines[2] = "  rate_hz: fast";
    CHECK(load_error(dir, lines) == file + ":3: loop.rate_hz: expected a number, got 'fast'");
  }
  SECTION("wrong type of a section") {
    lines[12] = "faults: 3";
    lines.erase(lines.begin() + 13);
    CHECK_THAT(load_error(dir, lines), Catch::StartsWith(file + ":13: faults: expected a map"));
  }
  SECTION("out-of-range value") {
    lines[13] = "  missing_frame_limit: 0";
    CHECK(load_error(dir, lines) == file + ":14: faults.missing_frame_limit: value 0 outside [1, 1000]");
  }
  SECTION("a word where a choice is expected") {
    lines[11] = "  mode: fastest";
    CHECK_THAT(load_error(dir, lines), Catch::StartsWith(file + ":12: commutation.mode: expected original, classical"));
  }
  SECTION("missing motor_file") {
    lines.erase(lines.begin());
    CHECK_THAT(load_error(dir, lines),
               Catch::StartsWith(file) && Catch::Contains("(top level): missing key 'motor_file'"));
  }
  SECTION("motor_file that does not exist") {
    lines[0] = "motor_file: no-such-motor.yaml";
    CHECK_THAT(load_error(dir, lines),
               Catch::StartsWith(file + ":1: motor_file: file '") && Catch::Contains("no-such-motor.yaml' does not exist"));
  }
  SECTION("missing control.mass_kg (no default: the PID is tuned for it)") {
    lines.erase(lines.begin() + 8);
    CHECK_THAT(load_error(dir, lines), Catch::StartsWith(file + ":") && Catch::Contains(": control: missing key 'mass_kg'"));
  }
  SECTION("missing control section") {
    lines.erase(lines.begin() + 7, lines.begin() + 10);
    CHECK_THAT(load_error(dir, lines), Catch::StartsWith(file) && Catch::Contains("missing key 'control'"));
  }
  SECTION("mode pgnn without pgnn_model_file") {
    lines[11] = "  mode: pgnn";
    CHECK(load_error(dir, lines) == file + ":12: commutation.mode: mode needs commutation.pgnn_model_file");
  }
  SECTION("a model file that does not exist") {
    lines.insert(lines.begin() + 12, "  pgnn_model_file: models/pgnn.yaml");
    CHECK_THAT(load_error(dir, lines), Catch::StartsWith(file + ":13: commutation.pgnn_model_file: file '") &&
                                           Catch::Contains("models/pgnn.yaml' does not exist"));
  }
  SECTION("bus load above 70 % on a CAN interface") {
    lines[2] = "  rate_hz: 4000";
    lines[5] = "  interface: vcan0";
    CHECK_THAT(load_error(dir, lines),
               Catch::StartsWith(file + ":3: loop.rate_hz: can bus load: ") && Catch::Contains("exceeds the 70.0 % limit"));
  }
  SECTION("the in-process simulated bus has no bitrate: 4 kHz is accepted there") {
    lines[2] = "  rate_hz: 4000";
    CHECK(load_error(dir, lines).empty());
  }
  SECTION("motion limits: defaults, stop limits default to the move limits") {
    lines.push_back("motion:");
    lines.push_back("  acceleration_m_per_s2: 4.0");
    lines.push_back("  jerk_m_per_s3: 800.0");
    REQUIRE(load_error(dir, lines).empty());
    const auto config = servod::load_servod_config(file);
    CHECK(config.servo.motion_limits.velocity_m_per_s == 0.5);
    CHECK(config.servo.stop_limits.deceleration_m_per_s2 == 4.0);
    CHECK(config.servo.stop_limits.jerk_m_per_s3 == 800.0);
    CHECK(config.servo.quick_stop_limits.deceleration_m_per_s2 == 4.0);
    CHECK(config.servo.quick_stop_limits.jerk_m_per_s3 == 800.0);
  }
  SECTION("motion limit out of range") {
    lines.push_back("motion:");
    lines.push_back("  velocity_m_per_s: -1");
    CHECK_THAT(load_error(dir, lines), Catch::StartsWith(file + ":18: motion.velocity_m_per_s: value -1 outside ["));
  }
  SECTION("quick-stop deceleration below the stop's") {
    lines.push_back("motion:");
    lines.push_back("  stop_deceleration_m_per_s2: 8.0");
    lines.push_back("  quick_stop_deceleration_m_per_s2: 5.0");
    CHECK_THAT(load_error(dir, lines),
               Catch::StartsWith(file + ":19: motion.quick_stop_deceleration_m_per_s2: must not be below the stop"));
  }
  SECTION("quick-stop jerk below the stop's") {
    lines.push_back("motion:");
    lines.push_back("  quick_stop_jerk_m_per_s3: 10.0");
    CHECK_THAT(load_error(dir, lines),
               Catch::StartsWith(file + ":18: motion.quick_stop_jerk_m_per_s3: must not be below the stop"));
  }
  SECTION("soft limits the wrong way round") {
    lines.insert(lines.begin() + 10, "  soft_limit_min_m: 0.05");
    lines.insert(lines.begin() + 11, "  soft_limit_max_m: -0.05");
    CHECK_THAT(load_error(dir, lines), Catch::StartsWith(file + ":12: control.soft_limit_max_m: must be above"));
  }
}

TEST_CASE("commutation files for another motor or of the wrong kind are refused naming both files",
          "[daemon][config]") {
  test::TemporaryDirectory dir("clm-servod-config");
  // A model and a calibration made for the two-coil-set motor.
  const auto other = sim::load_motor_parameters(test::source_path("config/motor-sim-2coil.yaml"));
  const std::string other_model = dir.file("pgnn-2coil.yaml");
  const std::string other_calibration = dir.file("calibration-2coil.yaml");
  test::write_text(other_model, format_model_file(test::truth_pgnn(other)));
  test::write_text(other_calibration, format_calibration_file(test::truth_calibration(other)));
  const std::string motor_file = test::absolute_encoder_file("motor-sim.yaml");

  const auto refused = [&](const std::string& commutation_lines) {
    auto lines = valid_lines();
    lines[11] = commutation_lines;
    test::write_text(dir.file("servod.yaml"), join(lines));
    const auto config = servod::load_servod_config(dir.file("servod.yaml"));  // the files exist: loads
    try {
      servod::WiredAxis axis(config);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  SECTION("pgnn model of the two-coil motor") {
    CHECK(refused("  mode: pgnn\n  pgnn_model_file: " + other_model) ==
          other_model + ": motor.coil_sets: model has 2 coil sets, " + motor_file + " has 3");
  }
  SECTION("calibration of the two-coil motor, even when another mode is selected") {
    CHECK(refused("  mode: original\n  calibration_file: " + other_calibration) ==
          other_calibration + ": motor.coil_sets: calibration has 2 coil sets, " + motor_file + " has 3");
  }
  SECTION("a spline model where the pgnn model belongs") {
    const std::string spline = dir.file("spline.yaml");
    test::write_text(spline, format_model_file(test::truth_spline(sim::load_motor_parameters(motor_file))));
    CHECK_THAT(refused("  mode: pgnn\n  pgnn_model_file: " + spline),
               Catch::StartsWith(spline + ": kind: the file holds a spline model"));
  }
  SECTION("a corrupt model file") {
    const std::string corrupt = dir.file("corrupt.yaml");
    const std::string text = format_model_file(test::truth_pgnn(sim::load_motor_parameters(motor_file)));
    test::write_text(corrupt, text.substr(0, text.size() / 2));
    CHECK_THAT(refused("  mode: pgnn\n  pgnn_model_file: " + corrupt), Catch::StartsWith(corrupt + ":"));
  }
}

TEST_CASE("a bandwidth that keeps less than the least margins on the described plant is refused at start-up",
          "[daemon][config]") {
  // The motor file describes a 270 Hz mode, a 1.35 kHz current loop and
  // 0.27 ms of delays (docs/servod.md, "The position loop's margins"): 40 Hz
  // keeps about 33° and 10 dB, 130 Hz below 10° (the hold's ωT/2 and the
  // delays' 360·f·τ take 36° of the rule's 45.6°).
  test::TemporaryDirectory dir("clm-servod-config");
  std::ifstream in(test::ideal_plant_file("motor-sim.yaml"));  // the shipped motor without its plant terms
  std::stringstream motor;
  motor << in.rdbuf();
  std::string text = motor.str();
  const std::string drive = "\ndrive:\n", stroke = "  stroke_max_m: 0.12\n";
  REQUIRE(text.find(drive) != std::string::npos);
  text.insert(text.find(drive) + drive.size(),
              "  setpoint_delay_s: 1.8e-4\n  position_delay_s: 9.0e-5\n"
              "  current_loop: {bandwidth_Hz: 1350.0, phase_resistance_ohm: 2.2, phase_inductance_H: 0.0011}\n");
  REQUIRE(text.find(stroke) != std::string::npos);
  text.insert(text.find(stroke) + stroke.size(), "  flexible_mode: {frequency_Hz: 270.0, damping_ratio: 0.02}\n");
  test::write_text(dir.file("motor.yaml"), text);
  auto lines = valid_lines();
  lines[0] = "motor_file: " + dir.file("motor.yaml");
  REQUIRE(load_error(dir, lines).empty());
  const servod::ServodConfig config = servod::load_servod_config(dir.file("servod.yaml"));
  CHECK(config.plant.mode_frequency_Hz == 270.0);
  CHECK(config.plant.delay_s == Approx(2.7e-4));
  CHECK(config.plant.current_loop_bandwidth_Hz == 1350.0);
  CHECK(config.plant.mass_kg == 15.0);
  lines[9] = "  bandwidth_hz: 130.0";
  CHECK_THAT(load_error(dir, lines),
             Catch::StartsWith(dir.file("servod.yaml") + ":10: control.bandwidth_hz: the position loop tuned for 130 Hz "
                                                         "is unstable ("));
  lines[9] = "  bandwidth_hz: 55.0";  // stable, 28 deg of phase margin
  CHECK_THAT(load_error(dir, lines), Catch::Contains(":10: control.bandwidth_hz: the position loop tuned for 55 Hz is "
                                                     "short of the least margins (phase margin "));
  // The mode's own keys are checked as every key is.
  std::string bad = text;
  bad.replace(bad.find("frequency_Hz: 270.0"), 19, "frequency_Hz: -5.0");
  test::write_text(dir.file("motor.yaml"), bad);
  lines[9] = "  bandwidth_hz: 40.0";
  CHECK_THAT(load_error(dir, lines), Catch::Contains("motor.flexible_mode.frequency_Hz"));
}
