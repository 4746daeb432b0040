// The simulated drive with profile phase_current: it applies exactly the
// commanded currents (held over the period, ideal current loop), with the
// same current limit, watchdog and refusals as the magnitude/phase drive;
// the CAN nodes pass the decoded RPDO currents to it; and it refuses the
// other profile's setpoints.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <limits>
#include <stdexcept>

#include "commutation/model_file.hpp"
#include "drivers/can/can_protocol.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/motor_file.hpp"
#include "drivers/sim/sim_support.hpp"
#include "drivers/sim/simulated_nodes.hpp"
#include "support/allocation_counter.hpp"

using namespace clm;
using namespace clm::sim;

namespace {

constexpr double kPeriod = 1e-3;

MotorParameters phase_current_motor(int coil_sets) {
  MotorParameters parameters = fixtures::ideal_motor(coil_sets);
  parameters.drive.profile = DriveProfile::kPhaseCurrent;
  return parameters;
}

double peak(double ia, double ib) { return std::max({std::abs(ia), std::abs(ib), std::abs(ia + ib)}); }

}  // namespace

TEST_CASE("the phase-current drive applies exactly the commanded currents over the whole period, also in motion",
          "[sim][motor][phase_current]") {
  SimulatedMotor motor(phase_current_motor(3));
  motor.reset(0.0);
  double largest_speed = 0.0;
  for (int k = 0; k < 500; ++k) {
    const double t = k * kPeriod;
    const PhaseCurrentSetpoint currents[3] = {{3.0 * std::sin(40.0 * t), -1.5 + 0.001 * k},
                                              {-2.0, 2.5 * std::cos(25.0 * t)},
                                              {0.25 * (k % 7), -0.125 * (k % 5)}};
    REQUIRE(motor.command_currents(currents, true) == CommandResult::kAccepted);
    REQUIRE(motor.step(kPeriod) == StepResult::kOk);
    const TruthState truth = motor.truth();
    largest_speed = std::max(largest_speed, std::abs(truth.velocity_m_per_s));
    for (int l = 0; l < 3; ++l) {
      REQUIRE(truth.currents_A[2 * l] == currents[l].ia_A);
      REQUIRE(truth.currents_A[2 * l + 1] == currents[l].ib_A);
    }
    // The wrench is the truth's Σ K^l(y) i^l + F_cog(y) + the direction-dependent term.
    Wrench expected = motor.true_cogging(truth.position_m) + motor.direction_dependent(truth.velocity_m_per_s);
    for (int l = 0; l < 3; ++l) {
      expected += motor.true_gain(l, truth.position_m) * Eigen::Vector2d(currents[l].ia_A, currents[l].ib_A);
    }
    REQUIRE((truth.wrench - expected).norm() < 1e-9);
    REQUIRE(motor.status().enabled());
    REQUIRE_FALSE(motor.status().current_limited());
  }
  REQUIRE(largest_speed > 1e-3);  // the translator moved: the currents did not follow the position
}

TEST_CASE("the phase-current drive limits a coil set's currents like the magnitude/phase drive",
          "[sim][motor][phase_current]") {
  MotorParameters parameters = phase_current_motor(2);
  parameters.drive.phase_current_limit_A = 5.0;
  SimulatedMotor motor(parameters);
  const PhaseCurrentSetpoint currents[2] = {{8.0, -2.0}, {1.0, 0.5}};  // peak |i_a| = 8 A > 5 A
  REQUIRE(motor.command_currents(currents, true) == CommandResult::kAccepted);
  motor.step(kPeriod);
  const TruthState truth = motor.truth();
  REQUIRE(peak(truth.currents_A[0], truth.currents_A[1]) == Approx(5.0).epsilon(1e-12));
  REQUIRE(truth.currents_A[0] == Approx(8.0 * 5.0 / 8.0).epsilon(1e-12));
  REQUIRE(truth.currents_A[1] == Approx(-2.0 * 5.0 / 8.0).epsilon(1e-12));
  REQUIRE(truth.currents_A[2] == 1.0);
  REQUIRE(truth.currents_A[3] == 0.5);
  REQUIRE(motor.status().current_limited());
}

TEST_CASE("the phase-current drive stops the current when disabled and when its watchdog expires",
          "[sim][motor][phase_current]") {
  SimulatedMotor motor(phase_current_motor(1));
  const PhaseCurrentSetpoint currents[1] = {{2.0, -1.0}};
  REQUIRE(motor.command_currents(currents, false) == CommandResult::kAccepted);
  motor.step(kPeriod);
  REQUIRE(motor.truth().currents_A.isZero());
  REQUIRE(motor.command_currents(currents, true) == CommandResult::kAccepted);
  motor.step(kPeriod);
  REQUIRE(motor.truth().currents_A[0] == 2.0);
  for (int k = 0; k < 6; ++k) motor.step(kPeriod);  // 6 ms > 5 ms without a command
  REQUIRE(motor.status().watchdog());
  REQUIRE(motor.status().fault());
  REQUIRE(motor.truth().currents_A.isZero());
}

TEST_CASE("each drive refuses the other profile's setpoints and bad currents, and latches a fault",
          "[sim][motor][phase_current]") {
  const PhaseCurrentSetpoint currents[2] = {{1.0, 0.0}, {0.0, 1.0}};
  const DriveSetpoint setpoints[2] = {{10.0, 0.0}, {10.0, 0.0}};
  {
    SimulatedMotor motor(phase_current_motor(2));
    REQUIRE(motor.command(setpoints, true) == CommandResult::kWrongProfile);
    REQUIRE(motor.status().invalid_setpoint());
    REQUIRE(motor.status().fault());
  }
  {
    SimulatedMotor motor(fixtures::ideal_motor(2));
    REQUIRE(motor.command_currents(currents, true) == CommandResult::kWrongProfile);
    REQUIRE(motor.status().invalid_setpoint());
  }
  SimulatedMotor motor(phase_current_motor(2));
  REQUIRE(motor.command_currents(std::span<const PhaseCurrentSetpoint>(currents, 1), true) ==
          CommandResult::kWrongCoilSetCount);
  motor.clear_fault();
  const PhaseCurrentSetpoint not_finite[2] = {{1.0, std::numeric_limits<double>::quiet_NaN()}, {0.0, 0.0}};
  REQUIRE(motor.command_currents(not_finite, true) == CommandResult::kNotFinite);
  REQUIRE(motor.status().invalid_setpoint());
  REQUIRE(motor.truth().currents_A.isZero());
}

TEST_CASE("the simulated nodes apply the phase currents of the RPDOs and refuse a protocol of the other profile",
          "[sim][nodes][phase_current]") {
  SimulatedMotor motor(phase_current_motor(3));
  can::ProtocolConfig protocol;
  protocol.coil_sets = 3;
  protocol.drive_profile = DriveProfile::kPhaseCurrent;
  SimulatedNodes nodes(motor, protocol, kPeriod);

  can::SetpointCommand command;
  command.coil_sets = 3;
  command.enable = true;
  command.currents[0] = {1.2344, -0.0006};   // rounds to 1.234, -0.001
  command.currents[1] = {-9.999, 4.5};
  command.currents[2] = {0.0015, 7.25};      // rounds to 0.002
  std::array<can::Frame, 3> frames{};
  can::CodecStatus status = can::CodecStatus::kWrongId;
  const std::size_t count = can::encode_setpoints(protocol, command, frames, status);
  REQUIRE(count == 2);
  std::array<can::Frame, 2> replies{};
  can::Frame sync;
  REQUIRE(can::encode_sync(1, sync) == can::CodecStatus::kOk);
  REQUIRE(nodes.on_frame(sync, replies) == 2);
  for (std::size_t f = 0; f < count; ++f) REQUIRE(nodes.on_frame(frames[f], replies) == 0);
  REQUIRE(nodes.counters().setpoints_applied == 1);
  REQUIRE(nodes.counters().frames_rejected == 0);
  // The decoded values, exactly: raw mA / 1000.
  const double expected[6] = {1.234, -0.001, -9.999, 4.5, 0.002, 7.25};
  const TruthState truth = motor.truth();
  for (int k = 0; k < 6; ++k) REQUIRE(truth.currents_A[k] == expected[k]);
  REQUIRE(motor.status().enabled());

  can::ProtocolConfig other = protocol;
  other.drive_profile = DriveProfile::kMagnitudePhase;
  REQUIRE_THROWS_WITH(SimulatedNodes(motor, other, kPeriod),
                      Catch::Contains("magnitude_phase") && Catch::Contains("phase_current"));
}

TEST_CASE("a phase-current command and step do not allocate", "[sim][motor][phase_current][allocation]") {
  SimulatedMotor motor(phase_current_motor(4));
  PhaseCurrentSetpoint currents[4] = {{1.0, 0.0}, {0.0, 1.0}, {-1.0, 0.5}, {0.5, -1.0}};
  clm::test::AllocationScope scope;
  for (int k = 0; k < 1000; ++k) {
    currents[0].ia_A = 1e-3 * k;
    motor.command_currents(currents, true);
    motor.step(kPeriod);
    motor.sense();
  }
  const std::size_t allocations = scope.allocations();
  CHECK(allocations == 0);
}

TEST_CASE("drive.profile reads magnitude_phase and phase_current and refuses anything else with file, line, key, value",
          "[sim][motor_file][phase_current]") {
  const auto text_with = [](const std::string& profile_line) {
    std::ifstream in(fixtures::source_path("config/motor-sim.yaml"));
    std::stringstream buffer;
    buffer << in.rdbuf();
    std::string text = buffer.str();
    const std::string old_line = "  profile: magnitude_phase";
    const auto at = text.find(old_line);
    REQUIRE(at != std::string::npos);
    return text.replace(at, text.find('\n', at) - at, profile_line);
  };
  const auto parse = [](const std::string& text) {
    return read_motor_parameters(yaml::Node::load_string(text, "motor.yaml"));
  };
  CHECK(parse(text_with("  profile: magnitude_phase")).drive.profile == DriveProfile::kMagnitudePhase);
  CHECK(parse(text_with("  profile: phase_current")).drive.profile == DriveProfile::kPhaseCurrent);
  CHECK(parse(text_with("")).drive.profile == DriveProfile::kMagnitudePhase);  // the default
  CHECK(fixtures::default_motor().drive.profile == DriveProfile::kMagnitudePhase);
  CHECK(load_motor_parameters(fixtures::source_path("config/motor-sim-phase-current.yaml")).drive.profile ==
        DriveProfile::kPhaseCurrent);
  // The line of the key in config/motor-sim.yaml.
  std::ifstream in(fixtures::source_path("config/motor-sim.yaml"));
  int line = 0, profile_line = 0;
  for (std::string row; std::getline(in, row);) {
    ++line;
    if (row.rfind("  profile:", 0) == 0) profile_line = line;
  }
  REQUIRE(profile_line > 0);
  for (const char* bad : {"phase-current", "current", "MAGNITUDE_PHASE", "1"}) {
    INFO(bad);
    REQUIRE_THROWS_WITH(parse(text_with(std::string("  profile: ") + bad)),
                        Catch::StartsWith("motor.yaml:" + std::to_string(profile_line) + ": drive.profile: ") &&
                            Catch::Contains(std::string("'") + bad + "'"));
  }
  // The same check where every tool reads the motor (clm::read_motor_description).
  REQUIRE_THROWS_WITH(read_motor_description(yaml::Node::load_string(text_with("  profile: both"), "m.yaml")),
                      Catch::Contains("drive.profile") && Catch::Contains("'both'"));
}
