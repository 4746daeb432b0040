// The drive's own signals (drivers/drive_signals.hpp; docs/servod.md, "The
// drive's own signals"), each set in the simulated drive and met with its
// documented reaction: the enable handshake (Enabled), a drive that stops
// reporting Enabled, the current limit's duration (CurrentLimited) and a
// limit switch (EndStop). The drive's fault bit (206) and its watchdog (211)
// have their tests in test_faults.cpp and test_stops.cpp.
#include <catch2/catch.hpp>

#include <cmath>

#include "daemon/servod/axis_wiring.hpp"
#include "daemon_support.hpp"
#include "drivers/sim/motor_file.hpp"
#include "support/ideal_plant.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::Fault;
using servo::ServoState;

namespace {

/// The ideal plant's daemon on its motor with `change` applied to the motor's parameters.
template <class Change>
servod::WiredAxis& wired_with(std::unique_ptr<servod::WiredAxis>& holder, const servod::ServodConfig& config,
                              Change change) {
  sim::MotorParameters parameters = sim::load_motor_parameters(test::ideal_plant_file("motor-sim.yaml"));
  change(parameters);
  holder = std::make_unique<servod::WiredAxis>(config, servod::wire_simulated_axis(config, parameters));
  holder->daemon.run_cycles(10);
  return *holder;
}

/// Enables the axis and runs until the drive reports Enabled and the axis is driven.
void enable_through_handshake(servod::WiredAxis& wired) {
  test::command(wired.daemon, Kind::kEnable, 1);
  test::require_driving_output(wired);
}

servod::CommandReply move_to(servod::ServoDaemon& daemon, double target_m, control::MotionLimits limits) {
  servo::Command move;
  move.kind = Kind::kMoveTo;
  move.target_m = target_m;
  move.limits = limits;
  return daemon.submit(move);
}

}  // namespace

TEST_CASE("enable completes when the drive reports Enabled: zero setpoints with enable meanwhile, a move waits",
          "[daemon][drive-signals]") {
  const auto config = test::ideal_plant_config();
  std::unique_ptr<servod::WiredAxis> holder;
  auto& wired = wired_with(holder, config, [](sim::MotorParameters& p) { p.drive.enable_delay_s = 0.02; });
  auto& daemon = wired.daemon;
  const double start_m = wired.simulated_motor()->truth().position_m;
  test::command(daemon, Kind::kEnable, 1);
  REQUIRE(daemon.cycle().status().state == ServoState::kEnabled);
  // A move offered while the drive is not yet enabled is taken, its clock held at its start.
  REQUIRE(move_to(daemon, start_m + 0.01, {0.1, 2.0, 500.0}).accepted());
  int enabling_cycles = 0;
  const double hold_m = daemon.cycle().record().r_m;  // where the axis was at the enable
  while (daemon.cycle().status().enabling) {
    const auto sent = test::sent_setpoints(wired);
    INFO("enabling cycle " << enabling_cycles);
    REQUIRE(sent.complete);
    CHECK(sent.command.enable);
    CHECK(sent.all_magnitudes_zero());
    CHECK(daemon.cycle().record().program_time_s == 0.0);
    CHECK(daemon.cycle().record().r_m == hold_m);
    CHECK_FALSE(wired.simulated_motor()->status().enabled());
    daemon.run_cycles(1);
    REQUIRE(++enabling_cycles < 100);
  }
  // The drive's 20 ms, seen one period after the drive applies them; within the 100 ms timeout.
  INFO("enabling took " << enabling_cycles << " cycles");
  CHECK(enabling_cycles >= 20);
  CHECK(enabling_cycles <= 23);
  REQUIRE(daemon.cycle().status().state == ServoState::kEnabled);
  test::require_driving_output(wired);
  // The move then runs whole from its start.
  REQUIRE(daemon.run_until_idle(5000) < 5000);
  CHECK(daemon.cycle().status().state == ServoState::kEnabled);
  CHECK(std::abs(wired.simulated_motor()->truth().position_m - (start_m + 0.01)) < 1e-5);
}

TEST_CASE("a drive that does not report Enabled within enable_timeout_s latches kDriveNotEnabled",
          "[daemon][drive-signals]") {
  auto config = test::ideal_plant_config();
  config.servo.enable_timeout_s = 0.05;
  std::unique_ptr<servod::WiredAxis> holder;
  auto& wired = wired_with(holder, config, [](sim::MotorParameters& p) { p.drive.enable_delay_s = 0.2; });
  auto& daemon = wired.daemon;
  test::command(daemon, Kind::kEnable, 1);
  const auto cycles = test::run_until_fault(daemon, 100);
  INFO("fault after " << cycles << " cycles");
  // Past the 50 ms, in the first cycle whose feedback still says not enabled.
  CHECK(cycles >= 50);
  CHECK(cycles <= 52);
  CHECK(daemon.cycle().status().fault == Fault::kDriveNotEnabled);
  CHECK_FALSE(daemon.cycle().status().enabling);
  test::require_safe_output(wired);
}

TEST_CASE("a drive that stops reporting Enabled without a fault of its own latches kDriveNotEnabled at once",
          "[daemon][drive-signals]") {
  const auto config = test::ideal_plant_config();
  std::unique_ptr<servod::WiredAxis> holder;
  auto& wired = wired_with(holder, config, [](sim::MotorParameters& p) { p.drive.enable_delay_s = 0.002; });
  auto& daemon = wired.daemon;
  enable_through_handshake(wired);
  // The drive restarts (a power glitch): disabled, no fault bit.
  sim::SimulatedMotor& motor = *wired.simulated_motor();
  motor.reset(motor.truth().position_m);
  CHECK(test::run_until_fault(daemon, 5) == 1);
  CHECK(daemon.cycle().status().fault == Fault::kDriveNotEnabled);
  CHECK(servo::reaction(Fault::kDriveNotEnabled) == servo::FaultReaction::kZeroSetpoints);
  test::require_safe_output(wired);
}

TEST_CASE("CurrentLimited is counted, and latches kDriveCurrentLimited with a quick stop when it lasts",
          "[daemon][drive-signals]") {
  auto config = test::ideal_plant_config();
  config.servo.current_limited_limit_s = 0.01;
  std::unique_ptr<servod::WiredAxis> holder;
  // 1 A: about 60 N of the motor's, below what a brisk move asks.
  auto& wired = wired_with(holder, config, [](sim::MotorParameters& p) { p.drive.phase_current_limit_A = 1.0; });
  auto& daemon = wired.daemon;
  enable_through_handshake(wired);
  const auto& counters = daemon.cycle().status().counters;
  REQUIRE(counters.current_limited_cycles == 0);
  const double start_m = wired.simulated_motor()->truth().position_m;
  REQUIRE(move_to(daemon, start_m + 0.05, {0.5, 10.0, 2000.0}).accepted());
  const auto cycles = test::run_until_fault(daemon, 500);
  INFO("fault after " << cycles << " cycles, " << counters.current_limited_cycles << " limited");
  REQUIRE(cycles <= 500);
  CHECK(daemon.cycle().status().fault == Fault::kDriveCurrentLimited);
  // 10 ms is ten cycles: the eleventh limited one in a row latches.
  CHECK(counters.current_limited_cycles >= 11);
  CHECK(servo::reaction(Fault::kDriveCurrentLimited) == servo::FaultReaction::kQuickStop);
  CHECK(daemon.cycle().status().fault_reaction_running);
}

TEST_CASE("a limit switch latches kEndStop with a quick stop, and the translator stops short of the hard stop",
          "[daemon][drive-signals]") {
  auto config = test::ideal_plant_config();
  std::unique_ptr<servod::WiredAxis> holder;
  // A limit switch 30 mm inside the soft limit, where a move may go.
  const double switch_m = config.servo.soft_limit_max_m - 0.03;
  auto& wired = wired_with(holder, config, [&](sim::MotorParameters& p) { p.mechanics.limit_switch_max_m = switch_m; });
  auto& daemon = wired.daemon;
  enable_through_handshake(wired);
  REQUIRE(move_to(daemon, switch_m + 0.02, {0.2, 5.0, 1000.0}).accepted());
  const auto cycles = test::run_until_fault(daemon, 2000);
  REQUIRE(cycles <= 2000);
  sim::SimulatedMotor& motor = *wired.simulated_motor();
  INFO("fault at " << motor.truth().position_m << " m, switch at " << switch_m << " m");
  CHECK(daemon.cycle().status().fault == Fault::kEndStop);
  CHECK(daemon.cycle().status().drive.end_stop);
  // The switch alone does not fault the drive: the loop stays closed for the stop.
  CHECK_FALSE(motor.status().fault());
  CHECK(motor.truth().position_m >= switch_m);
  CHECK(motor.truth().position_m < switch_m + 1e-3);
  REQUIRE(daemon.cycle().status().fault_reaction_running);
  test::require_driving_output(wired);
  while (daemon.cycle().status().fault_reaction_running) daemon.run_cycles(1);
  // At rest within the quick stop's distance of 0.2 m/s (1 mm at 20 m/s²), far from the hard stop.
  CHECK(motor.truth().position_m < switch_m + 0.005);
  CHECK(motor.truth().end_stop_collisions == 0);
  test::require_safe_output(wired);
}

TEST_CASE("a jog started while the drive enables counts its silence from the loop closing", "[daemon][drive-signals]") {
  // A drive slower to enable than the jog's timeout: without the renewal
  // clock held, the jog would stop in the cycle the loop closes.
  auto config = test::ideal_plant_config();
  config.servo.enable_timeout_s = 0.5;
  std::unique_ptr<servod::WiredAxis> holder;
  auto& wired = wired_with(holder, config, [](sim::MotorParameters& p) { p.drive.enable_delay_s = 0.3; });
  auto& daemon = wired.daemon;
  test::command(daemon, Kind::kEnable, 1);
  REQUIRE(daemon.cycle().status().enabling);
  servo::Command jog;
  jog.kind = Kind::kJog;
  jog.jog_velocity_m_per_s = 0.05;
  jog.limits = {0.05, 1.0, 1000.0};
  (void)daemon.take_replies();
  REQUIRE(daemon.submit(jog).answered_later());
  daemon.run_cycles(1);
  const auto started = daemon.take_replies();
  REQUIRE(started.size() == 1);
  REQUIRE(started[0].text() == "jog started");
  int cycles = 0;
  while (daemon.cycle().status().enabling) {
    daemon.run_cycles(1);
    REQUIRE(++cycles < 400);
  }
  INFO("enabling took " << cycles << " cycles, longer than the jog timeout " << config.servo.jog_timeout_s << " s");
  REQUIRE(cycles * config.servo.period_s > config.servo.jog_timeout_s);
  const double start_m = wired.simulated_motor()->truth().position_m;
  // No renewal since: it runs for its timeout from the loop closing, then stops.
  daemon.run_cycles(200);
  CHECK(daemon.cycle().status().counters.jog_timeouts == 0);
  CHECK(wired.simulated_motor()->truth().position_m > start_m + 0.003);
  daemon.run_cycles(400);
  CHECK(daemon.cycle().status().counters.jog_timeouts == 1);
  CHECK(daemon.cycle().status().state == ServoState::kEnabled);
}
