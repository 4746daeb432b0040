// The motor file: the repository's files load with the values they say, keys
// left out take their documented defaults, and bad files are refused with
// file, line and key path.
#include <catch2/catch.hpp>
#include <string>

#include "drivers/sim/motor.hpp"
#include "drivers/sim/motor_file.hpp"
#include "drivers/sim/sim_support.hpp"

using namespace clm;
using namespace clm::sim;

namespace {

// A complete small file; the line numbers below refer to it.
const std::string kMinimal =
    "motor:\n"                                    // 1
    "  pole_pitch_m: 0.03\n"                      // 2
    "  coil_sets: 2\n"                            // 3
    "drive:\n"                                    // 4
    "  commutation:\n"                            // 5
    "    motor_constant_N_per_A: 67.0\n"          // 6
    "    phase_offset_rad: -0.52\n"               // 7
    "simulation:\n"                               // 8
    "  coil_sets:\n"                              // 9
    "    - motor_constant_N_per_A: 61.0\n"        // 10
    "      phase_offset_rad: -0.5\n"              // 11
    "    - motor_constant_N_per_A: 62.0\n"        // 12
    "      phase_offset_rad: -0.55\n"             // 13
    "  mechanics:\n"                              // 14
    "    translator_mass_kg: 15.0\n";             // 15

MotorParameters parse(const std::string& text) { return read_motor_parameters(yaml::Node::load_string(text, "motor.yaml")); }

std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const yaml::Error& e) {
    return e.what();
  }
  return "";
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

}  // namespace

TEST_CASE("the repository's motor files load with the values they state", "[sim][motor_file]") {
  const MotorParameters motor = fixtures::default_motor();
  REQUIRE(motor.coil_set_count() == 3);
  REQUIRE(motor.pole_pitch_m() == 0.03);
  REQUIRE(motor.drive.commutation.motor_constant_N_per_A == 67.0);
  REQUIRE(motor.drive.commutation.phase_offset_rad == -0.52);
  REQUIRE(motor.electromagnetics.coil_sets[0].motor_constant_N_per_A == 61.3);
  REQUIRE(motor.electromagnetics.coil_sets[1].motor_constant_N_per_A == 61.6);
  REQUIRE(motor.electromagnetics.coil_sets[2].motor_constant_N_per_A == 60.1);
  REQUIRE(motor.electromagnetics.coil_sets[0].phase_offset_rad == -0.54);
  REQUIRE(motor.electromagnetics.coil_sets[2].phase_offset_rad == -0.55);
  REQUIRE(motor.mechanics.translator_mass_kg == 15.0);
  REQUIRE(motor.electromagnetics.cogging_periodic.size() == 3);
  REQUIRE(motor.sensors.force_noise_N_N_Nm == Wrench(0.85, 0.38, 0.73));
  REQUIRE_NOTHROW(SimulatedMotor(motor));

  const MotorParameters two = fixtures::two_coil_motor();
  REQUIRE(two.coil_set_count() == 2);
  REQUIRE(two.pole_pitch_m() == 0.024);
  REQUIRE(two.drive.commutation.motor_constant_N_per_A == 50.0);
  REQUIRE(two.electromagnetics.coil_sets[1].lever_arm_m == 0.04);
  REQUIRE_NOTHROW(SimulatedMotor(two));
}

TEST_CASE("keys left out take their documented defaults", "[sim][motor_file]") {
  const MotorParameters motor = parse(kMinimal);
  const MotorParameters defaults;
  REQUIRE(motor.stroke_min_m == -0.1);
  REQUIRE(motor.stroke_max_m == 0.1);
  REQUIRE(motor.mechanics.end_stop_min_m == Approx(-0.11));
  REQUIRE(motor.mechanics.end_stop_max_m == Approx(0.11));
  REQUIRE(motor.mechanics.integration_step_s == defaults.mechanics.integration_step_s);
  REQUIRE(motor.mechanics.viscous_friction_N_s_per_m == 0.0);
  REQUIRE(motor.mechanics.coulomb_friction_N == 0.0);
  REQUIRE(motor.drive.phase_current_limit_A == defaults.drive.phase_current_limit_A);
  REQUIRE(motor.drive.watchdog_timeout_s == defaults.drive.watchdog_timeout_s);
  REQUIRE(motor.electromagnetics.seed == defaults.electromagnetics.seed);
  REQUIRE(motor.electromagnetics.coil_sets[1].lever_arm_m == 0.0);
  // No parasitic unless asked for.
  REQUIRE(motor.electromagnetics.magnet_intensity.rms == 0.0);
  REQUIRE(motor.electromagnetics.cogging_periodic.empty());
  REQUIRE(motor.electromagnetics.direction_dependent_N_N_Nm.isZero(0.0));
  REQUIRE(motor.sensors.force_noise_N_N_Nm.isZero(0.0));
}

TEST_CASE("bad motor files are refused with file, line and key path", "[sim][motor_file]") {
  REQUIRE(error_of(kMinimal).empty());
  struct Case {
    const char* what;
    std::string text;
    std::string expected;
  };
  const Case cases[] = {
      {"unknown top-level section", kMinimal + "controller:\n  bandwidth_Hz: 40\n", "motor.yaml:16: controller: unknown key"},
      {"unknown key in motor", replaced(kMinimal, "  coil_sets: 2\n", "  coil_sets: 2\n  mass_kg: 3\n"),
       "motor.yaml:4: motor.mass_kg: unknown key"},
      {"unknown key in drive", replaced(kMinimal, "simulation:\n", "  current_limit_A: 3\nsimulation:\n"),
       "motor.yaml:8: drive.current_limit_A: unknown key"},
      {"unknown key in a coil set", replaced(kMinimal, "      phase_offset_rad: -0.5\n", "      phase_offset_rad: -0.5\n      pitch_m: 1\n"),
       "motor.yaml:12: simulation.coil_sets[0].pitch_m: unknown key"},
      {"unknown key in mechanics", kMinimal + "    mass_kg: 3\n", "motor.yaml:16: simulation.mechanics.mass_kg: unknown key"},
      {"missing mass", replaced(kMinimal, "    translator_mass_kg: 15.0\n", "    coulomb_friction_N: 1.0\n"),
       "motor.yaml:15: simulation.mechanics: missing key 'translator_mass_kg'"},
      {"missing simulation coil sets", replaced(replaced(replaced(replaced(replaced(kMinimal, "  coil_sets:\n    -", "  seed: 3\n    -"),
          "    - motor_constant_N_per_A: 61.0\n", ""), "      phase_offset_rad: -0.5\n", ""),
          "    - motor_constant_N_per_A: 62.0\n", ""), "      phase_offset_rad: -0.55\n", ""),
       "simulation: missing key 'coil_sets'"},
      {"missing drive commutation", replaced(kMinimal, "    phase_offset_rad: -0.52\n", ""),
       "drive.commutation: missing key 'phase_offset_rad'"},
      {"wrong type", replaced(kMinimal, "translator_mass_kg: 15.0", "translator_mass_kg: heavy"),
       "motor.yaml:15: simulation.mechanics.translator_mass_kg: expected a number, got 'heavy'"},
      {"negative mass", replaced(kMinimal, "translator_mass_kg: 15.0", "translator_mass_kg: -1"),
       "motor.yaml:15: simulation.mechanics.translator_mass_kg: value -1 must be positive"},
      {"coil set count mismatch", replaced(kMinimal, "  coil_sets: 2\n", "  coil_sets: 3\n"),
       "motor.yaml:10: simulation.coil_sets: 2 entries, motor.coil_sets says 3"},
      {"too many coil sets", replaced(kMinimal, "  coil_sets: 2\n", "  coil_sets: 9\n"),
       "motor.yaml:3: motor.coil_sets: value 9 outside [1, 8]"},
      {"out-of-range mismatch", kMinimal + "  phase_gain_mismatch_rms: 0.5\n",
       "motor.yaml:16: simulation.phase_gain_mismatch_rms: value 0.5 outside [0, 0.20000000000000001]"},
      {"triple with two values", kMinimal + "  sensors:\n    force_noise_N_N_Nm: [0.5, 0.3]\n",
       "motor.yaml:17: simulation.sensors.force_noise_N_N_Nm: expected [F_y, F_x, T_z], got 2 values"},
      {"negative noise", kMinimal + "  sensors:\n    force_noise_N_N_Nm: [0.5, -0.3, 0.1]\n",
       "motor.yaml:17: simulation.sensors.force_noise_N_N_Nm[1]: value -0.3 outside"},
      {"cogging order zero", kMinimal + "  cogging:\n    periodic:\n      - {order: 0, amplitude_N_N_Nm: [1, 0, 0]}\n",
       "motor.yaml:18: simulation.cogging.periodic[0].order: value 0 outside [1, 64]"},
      {"unknown key in the magnet track", kMinimal + "  magnet_track:\n    intensity: {rms: 0.01, length_m: 0.02}\n",
       "motor.yaml:17: simulation.magnet_track.intensity.length_m: unknown key"},
      {"end stop inside the stroke", replaced(kMinimal, "    translator_mass_kg: 15.0\n", "    translator_mass_kg: 15.0\n    end_stop_max_m: 0.05\n"),
       "motor.yaml:16: simulation.mechanics.end_stop_max_m: value 0.05 outside [0.10000000000000001"},
      {"integration step too coarse for the friction smoothing",
       replaced(kMinimal, "    translator_mass_kg: 15.0\n",
                "    translator_mass_kg: 15.0\n    coulomb_friction_N: 20\n    friction_smoothing_velocity_m_per_s: 1.0e-5\n"),
       "motor.yaml:15: simulation.mechanics: integration_step_s = 5.0000000000000002e-05: too large for the friction smoothing"},
      {"negative seed", kMinimal + "  seed: -3\n", "motor.yaml:16: simulation.seed: value -3 outside"},
      {"stroke reversed", replaced(kMinimal, "  coil_sets: 2\n", "  coil_sets: 2\n  stroke_min_m: 0.2\n"),
       "motor: stroke_max_m must be above stroke_min_m"},
      // docs/fuzzing.md: yaml-cpp's own conversion error
      // escaped without file or line; the simulator's knot count overflowed int.
      {"a list as a key", kMinimal + "? [a, b]\n: 1\n", "motor.yaml:16: (key): a list or map as a key"},
      {"slow cogging correlation length tiny against the travel",
       kMinimal + "  cogging:\n    slow: {rms_N_N_Nm: [1, 0, 0], correlation_length_m: 1.0e-12}\n",
       "motor.yaml:15: simulation.mechanics: cogging_slow_correlation_length_m = 9.9999999999999998e-13: gives"},
      {"end stops whose distance overflows",
       kMinimal + "    end_stop_min_m: -1.0e308\n    end_stop_max_m: 1.0e308\n  magnet_track:\n    intensity: {rms: 0.01}\n",
       "magnet_intensity.correlation_length_m = 0.02: gives inf spline knots"},
  };
  for (const auto& c : cases) {
    INFO(c.what);
    const std::string message = error_of(c.text);
    INFO("message: " << message);
    REQUIRE_THAT(message, Catch::Contains(c.expected));
  }
}

TEST_CASE("a file that cannot be opened names its path", "[sim][motor_file]") {
  REQUIRE_THROWS_WITH(load_motor_parameters("/nonexistent/motor.yaml"), Catch::Contains("/nonexistent/motor.yaml"));
}

TEST_CASE("a directory or device named as the motor file is refused, not read", "[sim][motor_file]") {
  // /dev/zero used to be read until memory ran out (docs/fuzzing.md).
  REQUIRE_THROWS_WITH(load_motor_parameters("/dev/zero"), Catch::Contains("/dev/zero: not a regular file"));
  REQUIRE_THROWS_WITH(load_motor_parameters("/tmp"), Catch::Contains("/tmp: not a regular file"));
}
