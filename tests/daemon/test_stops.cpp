// Motion that stays safe on the in-process simulated motor (virtual clock):
// stop and quick stop at speed follow a jerk-limited profile and come to rest
// within the soft limits without a fault; every fault injected at full speed
// gets its reaction from servo::kFaultReactions and the translator stays
// inside the end stops; moves beyond the motion limits or whose stop would
// leave the soft limits are refused; the axis comes back from outside the
// soft limits in restricted mode. Positions are checked on the simulator's
// truth, outputs on what went on the bus.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <string>

#include "daemon/control/stop_profile.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "daemon/telemetry/lcm_conversion.hpp"
#include "drivers/sim/in_process_bus.hpp"
#include "drivers/sim/motor.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::Fault;
using servo::FaultReaction;
using servo::ServoState;

namespace {

/// config/servod.yaml on the virtual clock, enabled at the centre.
struct Axis {
  explicit Axis(const servod::ServodConfig& config = test::ideal_plant_config()) : wired(config), daemon(wired.daemon) {
    daemon.run_cycles(10);
    test::command(daemon, Kind::kEnable, 20);
    REQUIRE(daemon.cycle().status().state == ServoState::kEnabled);
  }
  const servo::ServoSettings& settings() const { return daemon.config().servo; }
  sim::SimulatedMotor& motor() { return *wired.simulated_motor(); }
  sim::Injection& injection() { return wired.in_process_bus()->injection(); }
  const servo::CycleRecord& record() { return daemon.cycle().record(); }

  servod::CommandReply move_to(double target_m, control::MotionLimits limits) {
    servo::Command move;
    move.kind = Kind::kMoveTo;
    move.target_m = target_m;
    move.limits = limits;
    return daemon.submit(move);
  }
  /// A slow move to `target_m`, then settled.
  void go_to(double target_m) {
    REQUIRE(move_to(target_m, {0.1, 1.0, 1000.0}).accepted());
    daemon.run_until_idle(20000);
    daemon.run_cycles(300);
    REQUIRE(daemon.cycle().status().state == ServoState::kEnabled);
  }
  /// A move to `target_m` at the motion limits, run until it cruises at the largest velocity.
  void at_full_speed(double target_m) {
    REQUIRE(move_to(target_m, settings().motion_limits).accepted());
    while (std::abs(record().r_dot_m_per_s) < settings().motion_limits.velocity_m_per_s - 1e-9) {
      daemon.run_cycles(1);
      REQUIRE(record().program_running);
    }
  }
  /// The truth is inside the end stops of the motor.

  servod::WiredAxis wired;
  servod::ServoDaemon& daemon;
};

control::ReferenceSample reference_of(const servo::CycleRecord& record) {
  return {record.r_m, record.r_dot_m_per_s, record.r_ddot_m_per_s2, 0.0};
}

}  // namespace

TEST_CASE("stop and quick stop during a move at speed: no fault, within the soft limits and the stop limits, at rest "
          "in the predicted time",
          "[daemon][stops]") {
  const double speed = GENERATE(0.1, 0.3, 0.47, 0.5);
  const bool quick = GENERATE(false, true);
  // When the command comes: cycles after the move started (accelerating,
  // cruising, braking towards the target).
  const int after_cycles = GENERATE(20, 150, 380);
  INFO("speed " << speed << " m/s, " << (quick ? "quick stop" : "stop") << " after " << after_cycles << " cycles");
  Axis axis;
  const auto& s = axis.settings();
  REQUIRE(speed <= s.motion_limits.velocity_m_per_s);
  const control::StopLimits limits = quick ? s.quick_stop_limits : s.stop_limits;
  axis.go_to(-0.1);
  const control::MotionLimits move{speed, s.motion_limits.acceleration_m_per_s2, s.motion_limits.jerk_m_per_s3};
  REQUIRE(axis.move_to(0.1, move).accepted());
  for (int k = 0; k < after_cycles; ++k) axis.daemon.run_cycles(1);
  const bool moving = axis.record().program_running;
  const control::ReferenceSample from = reference_of(axis.record());
  const control::StopProfile planned = control::StopProfile::plan(from, limits);
  (void)axis.daemon.take_replies();
  servo::Command stop;
  stop.kind = quick ? Kind::kQuickStop : Kind::kStop;
  REQUIRE(axis.daemon.submit(stop).accepted());
  const auto stops_before = axis.daemon.cycle().status().counters;
  double previous_a = from.acceleration_m_per_s2;
  const double jerk_limit = std::max(limits.jerk_m_per_s3, move.jerk_m_per_s3);
  const auto max_cycles = static_cast<int>(std::ceil(planned.duration_s() / s.period_s)) + 1;
  int cycles = 0;
  while (true) {
    axis.daemon.run_cycles(1);
    ++cycles;
    const auto& r = axis.record();
    INFO("cycle " << cycles << " of the stop: r = " << r.r_m << " m, v = " << r.r_dot_m_per_s << " m/s, a = "
                  << r.r_ddot_m_per_s2 << " m/s^2, y = " << axis.motor().truth().position_m << " m");
    REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
    REQUIRE_FALSE(r.program_running);
    CHECK(std::abs(r.r_ddot_m_per_s2) <= std::max(limits.deceleration_m_per_s2, std::abs(from.acceleration_m_per_s2)) + 1e-9);
    CHECK(std::abs(r.r_ddot_m_per_s2 - previous_a) <= jerk_limit * s.period_s * (1 + 1e-9) + 1e-9);
    previous_a = r.r_ddot_m_per_s2;
    const double y = axis.motor().truth().position_m;
    REQUIRE(y >= s.soft_limit_min_m);
    REQUIRE(y <= s.soft_limit_max_m);
    if (!r.stopping) break;
    REQUIRE(cycles <= max_cycles);
  }
  const auto& r = axis.record();
  CHECK(r.r_dot_m_per_s == 0.0);
  CHECK(r.r_ddot_m_per_s2 == 0.0);
  CHECK(r.r_m == Approx(planned.rest_position_m()).margin(1e-12));
  CHECK(cycles <= max_cycles);
  // One stop planned, when the command was drained (none when the move had ended).
  CHECK(axis.daemon.cycle().status().counters.stops + axis.daemon.cycle().status().counters.quick_stops ==
        stops_before.stops + stops_before.quick_stops + (moving ? 1 : 0));
  // Settles where the reference rests, still enabled, no fault.
  axis.daemon.run_cycles(500);
  REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
  CHECK(std::abs(axis.motor().truth().position_m - planned.rest_position_m()) < 1e-4);
  CHECK(axis.daemon.cycle().status().counters.guard_stops == 0);
  // The axis takes a new move from there.
  REQUIRE(axis.move_to(0.0, {0.1, 1.0, 1000.0}).accepted());
  axis.daemon.run_until_idle(20000);
  CHECK(axis.daemon.cycle().status().state == ServoState::kEnabled);
}

TEST_CASE("move-to beyond the motion limits, or whose stop from some cycle would leave the soft limits, is refused "
          "with the reason",
          "[daemon][stops]") {
  Axis axis;
  const auto& s = axis.settings();
  CHECK(axis.move_to(0.05, s.motion_limits).accepted());  // at the limits
  axis.daemon.run_until_idle(20000);
  for (const control::MotionLimits& bad :
       {control::MotionLimits{0.8, 5.0, 1000.0}, control::MotionLimits{1e6, 5.0, 1000.0},
        control::MotionLimits{0.5, 1e3, 1000.0}, control::MotionLimits{0.5, 5.0, 1e12}}) {
    const auto reply = axis.move_to(0.05, bad);
    INFO(reply.text());
    CHECK_FALSE(reply.accepted());
    CHECK_THAT(reply.text(), Catch::Contains("exceeds the limit"));
  }
  // A move whose stop from some cycle would rest beyond the soft limit: with
  // gentle stop limits, a move that brakes harder than a stop can is refused.
  auto config = test::ideal_plant_config();
  config.servo.stop_limits = {1.0, 1000.0};
  config.servo.quick_stop_limits = {1.0, 1000.0};
  // Inside the safe envelope: a quick stop from the largest velocity within half the soft span.
  config.servo.motion_limits.velocity_m_per_s = 0.3;
  servod::WiredAxis gentle(config);
  gentle.daemon.run_cycles(10);
  test::command(gentle.daemon, Kind::kEnable, 20);
  servo::Command move;
  move.kind = Kind::kMoveTo;
  move.target_m = s.soft_limit_max_m - 0.005;
  move.limits = {0.3, 10.0, 1000.0};
  const auto reply = gentle.daemon.submit(move);
  INFO(reply.text());
  CHECK_FALSE(reply.accepted());
  CHECK_THAT(reply.text(), Catch::Contains("outside the soft limits"));
  // The same move braking no harder than the stop is accepted.
  move.limits = {0.3, 1.0, 1000.0};
  CHECK(gentle.daemon.submit(move).accepted());
  gentle.daemon.run_until_idle(20000);
  gentle.daemon.run_cycles(300);
  CHECK(gentle.daemon.cycle().status().state == ServoState::kEnabled);
  CHECK(gentle.daemon.cycle().status().counters.guard_stops == 0);
}

TEST_CASE("a program beyond the motion limits is refused as a whole when it is posted", "[daemon][stops]") {
  Axis axis;
  servod::ProgramFile program;
  program.start_m = 0.0;
  program.steps.push_back({0.05, {0.1, 1.0, 1000.0}, 0.1});
  program.steps.push_back({-0.05, {0.9, 1.0, 1000.0}, 0.1});
  const auto reply = axis.daemon.submit_program(program);
  INFO(reply.text());
  CHECK_FALSE(reply.accepted());
  CHECK_THAT(reply.text(), Catch::Contains("step 2") && Catch::Contains("velocity_m_per_s"));
  program.steps[1].limits.velocity_m_per_s = 0.5;
  CHECK(axis.daemon.submit_program(program).accepted());
}

TEST_CASE("the approach guard quick-stops a move whose reference could not stop inside the soft limits",
          "[daemon][stops]") {
  // A move planned by a caller that bypasses the daemon's checks, straight
  // into the cycle's handover, to a target beyond the soft limit: the guard
  // stops its reference at the limit. The feedforward of the simulated
  // translator keeps the axis on the reference while it brakes.
  auto config = test::ideal_plant_config();
  config.servo.feedforward = {15.0, 40.0, 15.0};
  Axis axis(config);
  const auto& s = axis.settings();
  axis.go_to(0.0);
  control::MoveProgram program(axis.daemon.cycle().mailbox().hold_position_m(),
                               {{s.soft_limit_max_m + 0.015, {0.5, 10.0, 1000.0}, 0.0}});
  REQUIRE(axis.daemon.cycle().mailbox().post_program(&program));
  int cycles = 0;
  while (axis.record().program_running || axis.record().stopping || cycles < 2) {
    axis.daemon.run_cycles(1);
    REQUIRE(++cycles < 5000);
    INFO("cycle " << cycles << ": r = " << axis.record().r_m << " m, v = " << axis.record().r_dot_m_per_s
                  << " m/s, y = " << axis.motor().truth().position_m << " m, fault "
                  << servo::describe(axis.daemon.cycle().status().fault));
    REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
    REQUIRE(axis.motor().truth().position_m <= s.soft_limit_max_m);
  }
  CHECK(axis.daemon.cycle().status().counters.guard_stops == 1);
  CHECK(axis.record().r_m <= s.soft_limit_max_m);
  axis.daemon.run_cycles(300);
  CHECK(axis.daemon.cycle().status().state == ServoState::kEnabled);
  CHECK(axis.motor().truth().position_m <= s.soft_limit_max_m);
  // Let the daemon forget the program before it goes out of scope.
  axis.daemon.request_disable();
  axis.daemon.run_cycles(1);
}

TEST_CASE("every fault injected at full speed gets the reaction of the table and the translator stays inside the end "
          "stops",
          "[daemon][stops][faults]") {
  // The force sensor's faults latch only in an experiment (test_faults.cpp);
  // at speed in service they are warnings (the test after this one).
  enum class How { kDropDrive, kSkipDriveAlive, kWrongDlc, kBusOff, kErrorPassive,
                   kFailSends, kFollowingError, kForceSaturated, kOverruns, kDriveFault, kSoftLimit };
  const How how = GENERATE(How::kDropDrive, How::kSkipDriveAlive,
                           How::kWrongDlc, How::kBusOff, How::kErrorPassive, How::kFailSends, How::kFollowingError,
                           How::kForceSaturated, How::kOverruns, How::kDriveFault, How::kSoftLimit);
  INFO("injection " << static_cast<int>(how));
  auto config = test::ideal_plant_config();
  // A push the loop cannot hold at its force limit trips the following error
  // first at the default 2 mm; for fault 204 alone the limit is 20 mm, and
  // the soft limits then lie 40 mm inside the stroke (the safe envelope).
  double end_m = 0.1;
  if (how == How::kForceSaturated) {
    config.servo.following_error_limit_m = 0.02;
    config.servo.soft_limit_min_m = config.servo.machine.stroke_min_m + 0.04;
    config.servo.soft_limit_max_m = config.servo.machine.stroke_max_m - 0.04;
    end_m = 0.07;
  }
  Axis axis(config);
  auto& wired = axis.wired;
  auto& daemon = axis.daemon;
  auto& injection = axis.injection();
  const auto& s = axis.settings();
  axis.go_to(-end_m);
  axis.at_full_speed(end_m);  // towards the other end
  if (how == How::kSoftLimit) {
    // Braking towards 0.1 m, the translator is pushed 15 mm ahead, past the
    // soft limit (a measurement still believed: within 10 following-error limits).
    while (daemon.cycle().record().r_m < 0.095) daemon.run_cycles(1);
  }
  Fault expected = Fault::kNone;
  const int limit = s.missing_frame_limit;
  switch (how) {
    case How::kDropDrive: injection.drop_drive_frames = limit; expected = Fault::kEncoderFrameMissing; break;
    case How::kSkipDriveAlive: injection.skip_drive_alive = 7; expected = Fault::kEncoderAliveJump; break;
    case How::kWrongDlc: injection.wrong_dlc_drive_frames = limit; expected = Fault::kFrameRejected; break;
    case How::kBusOff: injection.bus_state = drivers::BusState::kBusOff; expected = Fault::kBusOff; break;
    case How::kErrorPassive: injection.bus_state = drivers::BusState::kErrorPassive; expected = Fault::kBusErrorPassive; break;
    case How::kFailSends: injection.fail_sends = true; expected = Fault::kSendFailed; break;
    case How::kFollowingError: {
      // A push of the translator: 3 mm in one cycle, along the motion.
      auto& motor = *wired.simulated_motor();
      motor.push_to(motor.truth().position_m - 0.003, motor.truth().velocity_m_per_s);
      expected = Fault::kFollowingError;
      break;
    }
    case How::kForceSaturated:
      // Against the motion, 100 N more than the force limit, until the fault.
      wired.simulated_motor()->set_disturbance_force_N(-(s.force_limit_N + 100.0));
      expected = Fault::kForceSaturated;
      break;
    case How::kOverruns:
      for (int k = 0; k < s.overrun_limit; ++k) daemon.run_cycle_after(0.0, true);
      expected = Fault::kRepeatedOverruns;
      break;
    case How::kDriveFault:
      // A fault inside the drive (its watchdog, at a real drive's 5 ms, has
      // its own test in test_faults.cpp; the simulated motor's 100 ms lets
      // the following error trip first at full speed).
      wired.simulated_motor()->latch_internal_fault();
      expected = Fault::kDriveFault;
      break;
    case How::kSoftLimit: {
      auto& motor = *wired.simulated_motor();
      motor.push_to(s.soft_limit_max_m + 0.0005, motor.truth().velocity_m_per_s);
      expected = Fault::kPositionOutOfRange;
      break;
    }
  }
  const FaultReaction reaction = servo::reaction(expected);
  std::int64_t cycles = 0;
  if (daemon.cycle().status().state != ServoState::kFault) cycles = test::run_until_fault(daemon, 200);
  REQUIRE(cycles <= 200);
  REQUIRE(daemon.cycle().status().fault == expected);
  wired.simulated_motor()->set_disturbance_force_N(0.0);
  injection.fail_sends = false;
  injection.bus_state = drivers::BusState::kActive;
  // The fault cycle's output (faults found between cycles: the next cycle's).
  if (how == How::kOverruns || how == How::kFailSends) daemon.run_cycles(1);
  const auto sent = test::sent_setpoints(wired);
  REQUIRE(sent.complete);
  if (reaction == FaultReaction::kQuickStop) {
    CHECK(sent.command.enable);
    CHECK(daemon.cycle().status().fault_reaction_running);
    const control::StopProfile planned =
        control::StopProfile::plan(reference_of(daemon.cycle().record()), s.quick_stop_limits);
    const auto max_cycles = static_cast<int>(std::ceil(planned.duration_s() / s.period_s)) + 2;
    int k = 0;
    while (daemon.cycle().status().fault_reaction_running) {
      daemon.run_cycles(1);
      REQUIRE(++k <= max_cycles);
      REQUIRE(daemon.cycle().status().state == ServoState::kFault);
      REQUIRE(daemon.cycle().status().fault == expected);
      CHECK(std::abs(daemon.cycle().record().r_ddot_m_per_s2) <= s.quick_stop_limits.deceleration_m_per_s2 + 1e-9);
    }
    CHECK(std::abs(daemon.cycle().record().r_dot_m_per_s) == 0.0);
  } else {
    CHECK_FALSE(sent.command.enable);
    CHECK(sent.all_magnitudes_zero());
    CHECK_FALSE(daemon.cycle().status().fault_reaction_running);
  }
  // From here on zero, disabled, until the translator has come to rest.
  injection = sim::Injection{};
  for (int k = 0; k < 1500; ++k) {
    daemon.run_cycles(1);
    REQUIRE(daemon.cycle().status().state == ServoState::kFault);
    REQUIRE(daemon.cycle().status().fault == expected);
    test::require_safe_output(wired, how != How::kDriveFault);
    const auto& mechanics = wired.simulated_motor()->parameters().mechanics;
    const double y = wired.simulated_motor()->truth().position_m;
    REQUIRE(y > mechanics.end_stop_min_m);
    REQUIRE(y < mechanics.end_stop_max_m);
  }
  CHECK(std::abs(wired.simulated_motor()->truth().velocity_m_per_s) < 1e-3);
  CHECK(wired.simulated_motor()->truth().end_stop_collisions == 0);
}

TEST_CASE("the force sensor lost at full speed in service is a warning: the move ends at its target, no fault",
          "[daemon][stops][force_sensor]") {
  const bool jump = GENERATE(false, true);
  INFO((jump ? "alive-counter jump" : "frames missing"));
  Axis axis;
  const auto& s = axis.settings();
  axis.go_to(-0.1);
  axis.at_full_speed(0.1);
  if (jump) {
    axis.injection().skip_force_alive = 3;
  } else {
    axis.injection().drop_force_frames = 1000;  // for good
  }
  const servo::Fault expected = jump ? Fault::kForceAliveJump : Fault::kForceFrameMissing;
  bool warned = false;
  while (axis.record().program_running || axis.record().stopping) {
    axis.daemon.run_cycles(1);
    REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
    warned = warned || axis.daemon.cycle().status().force_sensor_warning == expected;
    REQUIRE(std::abs(axis.record().e_m) <= s.following_error_limit_m);
  }
  CHECK(warned);
  CHECK(axis.daemon.cycle().status().counters.force_sensor_losses == 1);
  axis.daemon.run_cycles(300);
  CHECK(std::abs(axis.motor().truth().position_m - 0.1) < 1e-5);
  CHECK(axis.daemon.cycle().status().state == ServoState::kEnabled);
}

TEST_CASE("a fault that distrusts the feedback, during a quick-stop reaction, zeroes the setpoints at once",
          "[daemon][stops][faults]") {
  // Following error at full speed starts a quick stop under position
  // control; encoder frames then stop coming: the stop must not go on
  // with a position it can no longer see.
  Axis axis;
  auto& wired = axis.wired;
  auto& daemon = axis.daemon;
  auto& injection = axis.injection();
  const auto& s = axis.settings();
  axis.at_full_speed(0.1);
  auto& motor = axis.motor();
  motor.push_to(motor.truth().position_m - 0.003, motor.truth().velocity_m_per_s);
  REQUIRE(test::run_until_fault(daemon, 200) <= 200);
  REQUIRE(daemon.cycle().status().fault == Fault::kFollowingError);
  REQUIRE(daemon.cycle().status().fault_reaction_running);
  daemon.run_cycles(5);
  REQUIRE(daemon.cycle().status().fault_reaction_running);  // still braking under position control
  REQUIRE(test::sent_setpoints(wired).command.enable);
  injection.drop_drive_frames = s.missing_frame_limit;
  int k = 0;
  while (daemon.cycle().status().fault_reaction_running) {
    daemon.run_cycles(1);
    REQUIRE(++k <= s.missing_frame_limit);
  }
  const auto sent = test::sent_setpoints(wired);
  REQUIRE(sent.complete);
  CHECK_FALSE(sent.command.enable);
  CHECK(sent.all_magnitudes_zero());
  CHECK(daemon.cycle().status().fault == Fault::kFollowingError);  // the first reason stays
  injection = sim::Injection{};
  for (int n = 0; n < 1500; ++n) {
    daemon.run_cycles(1);
    test::require_safe_output(wired, true);
    const auto& mechanics = motor.parameters().mechanics;
    REQUIRE(motor.truth().position_m > mechanics.end_stop_min_m);
    REQUIRE(motor.truth().position_m < mechanics.end_stop_max_m);
  }
}

TEST_CASE("a jog moves at its velocity while repeated and stops along the stop limits when the repeats stop",
          "[daemon][stops][jog]") {
  Axis axis;
  auto& daemon = axis.daemon;
  const auto& s = axis.settings();
  axis.go_to(0.05);  // 0.5 s of jog and its timeout stay well inside the lower soft limit
  servo::Command jog;
  jog.kind = Kind::kJog;
  jog.jog_velocity_m_per_s = -0.1;
  jog.limits = {0.1, 5.0, 1000.0};
  (void)daemon.take_replies();
  auto reply = daemon.submit(jog);
  REQUIRE(reply.accepted());
  CHECK(reply.answered_later());  // by the cycle, once it has taken the jog
  // A repeat before the cycle has taken the jog (a stalled loop) keeps it, and
  // the jog starts with its whole timeout.
  CHECK(daemon.cycle().mailbox().jog_pending());
  reply = daemon.submit(jog);
  REQUIRE(reply.accepted());
  CHECK(reply.text() == "jogging");
  CHECK(test::cycle_answer(daemon).text() == "jog started");
  CHECK_FALSE(daemon.cycle().mailbox().jog_pending());
  CHECK(daemon.cycle().mailbox().jogging());
  // Repeated every 0.1 s for 0.5 s: at the velocity, towards the lower limit.
  for (int k = 0; k < 5; ++k) {
    daemon.run_cycles(100);
    CHECK(daemon.cycle().mailbox().jogging());
    reply = daemon.submit(jog);
    REQUIRE(reply.accepted());
    CHECK(reply.text() == "jogging");
  }
  CHECK(axis.record().r_dot_m_per_s == Approx(-0.1));
  // Another velocity while it runs is refused; the jog goes on.
  servo::Command faster = jog;
  faster.jog_velocity_m_per_s = -0.2;
  faster.limits.velocity_m_per_s = 0.2;
  CHECK_THAT(daemon.submit(faster).text(), Catch::Contains("another jog runs"));
  // No more repeats: after jog_timeout_s the stop profile from the reference
  // of that cycle, within the stop limits, then at rest; no fault.
  const auto timeout_cycles = static_cast<int>(std::ceil(s.jog_timeout_s / s.period_s));
  int k = 0;
  while (daemon.cycle().mailbox().jogging()) {
    daemon.run_cycles(1);
    REQUIRE(++k <= timeout_cycles + 2);
  }
  CHECK(k >= timeout_cycles - 1);
  const control::StopProfile planned = control::StopProfile::plan(reference_of(axis.record()), s.stop_limits);
  const int stop_cycles = static_cast<int>(std::ceil(planned.duration_s() / s.period_s)) + 2;
  for (int n = 0; n < stop_cycles; ++n) {
    daemon.run_cycles(1);
    CHECK(std::abs(axis.record().r_ddot_m_per_s2) <= s.stop_limits.deceleration_m_per_s2 + 1e-9);
  }
  CHECK(axis.record().r_dot_m_per_s == 0.0);
  CHECK(daemon.cycle().mailbox().at_rest());
  CHECK(daemon.cycle().status().state == ServoState::kEnabled);
  CHECK(daemon.cycle().status().counters.jog_timeouts == 1);
  // A repeat after the stop starts a new jog.
  (void)daemon.take_replies();
  CHECK(daemon.submit(jog).answered_later());
  CHECK(test::cycle_answer(daemon).text() == "jog started");
}

TEST_CASE("a repeated jog ends a following-error limit short of the soft limit, jogs beyond the limits are refused",
          "[daemon][stops][jog]") {
  Axis axis;
  auto& daemon = axis.daemon;
  const auto& s = axis.settings();
  servo::Command jog;
  jog.kind = Kind::kJog;
  jog.jog_velocity_m_per_s = 0.5;
  jog.limits = s.motion_limits;
  REQUIRE(daemon.submit(jog).accepted());
  double highest_m = -1.0;
  for (int k = 0; k < 100 && (daemon.cycle().mailbox().jogging() || k == 0); ++k) {
    daemon.run_cycles(50);
    daemon.submit(jog);  // refused once the jog has ended at the limit
    highest_m = std::max(highest_m, axis.motor().truth().position_m);
  }
  CHECK_FALSE(daemon.cycle().mailbox().jogging());
  CHECK(axis.record().r_m == Approx(s.soft_limit_max_m - s.following_error_limit_m));
  CHECK(highest_m < s.soft_limit_max_m);
  CHECK(daemon.cycle().status().state == ServoState::kEnabled);
  CHECK_THAT(daemon.submit(jog).text(), Catch::Contains("at the soft limit in that direction already"));

  servo::Command bad = jog;
  bad.jog_velocity_m_per_s = -1.0;
  bad.limits.velocity_m_per_s = 1.0;
  CHECK_THAT(daemon.submit(bad).text(), Catch::Contains("velocity_m_per_s 1 m/s exceeds the limit 0.5 m/s"));
  bad = jog;
  bad.jog_velocity_m_per_s = 0.0;
  bad.limits.velocity_m_per_s = 0.0;
  CHECK_THAT(daemon.submit(bad).text(), Catch::Contains("must not be 0"));
  // Not while a move runs.
  REQUIRE(axis.move_to(0.0, {0.1, 1.0, 1000.0}).accepted());
  daemon.run_cycles(5);
  jog.jog_velocity_m_per_s = -0.1;
  jog.limits.velocity_m_per_s = 0.1;
  CHECK_THAT(daemon.submit(jog).text(), Catch::Contains("a program is running"));
}

TEST_CASE("after fault 202 the axis is enabled in restricted mode and only a slow move back inside is accepted",
          "[daemon][stops][faults]") {
  Axis axis;
  const auto& s = axis.settings();
  // The translator pushed past the soft limit by hand.
  axis.motor().push_to(s.soft_limit_max_m + 0.01);
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  REQUIRE(axis.daemon.cycle().status().fault == Fault::kPositionOutOfRange);
  axis.daemon.run_cycles(20);
  // clear-fault still re-latches at once while outside.
  test::command(axis.daemon, Kind::kClearFault);
  REQUIRE(axis.daemon.cycle().status().fault == Fault::kPositionOutOfRange);
  (void)axis.daemon.take_replies();
  test::command(axis.daemon, Kind::kEnable, 5);
  const auto replies = axis.daemon.take_replies();
  REQUIRE(replies.size() == 1);
  CHECK(replies[0].accepted());
  REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
  CHECK(axis.daemon.cycle().mailbox().restricted());
  CHECK(axis.record().restricted);
  CHECK(telemetry::to_message(axis.record()).restricted);  // CLM_SERVO_STATE says so too
  test::require_driving_output(axis.wired);
  // Refused: a program, a move at more than 10 % of the velocity limit, a target outside.
  servod::ProgramFile program;
  program.start_m = 0.0;
  program.steps.push_back({0.0, {0.01, 1.0, 1000.0}, 0.0});
  auto reply = axis.daemon.submit_program(program);
  CHECK_FALSE(reply.accepted());
  CHECK_THAT(reply.text(), Catch::Contains("restricted mode"));
  reply = axis.move_to(0.0, {0.1, 1.0, 1000.0});
  CHECK_FALSE(reply.accepted());
  CHECK_THAT(reply.text(), Catch::Contains("restricted mode") && Catch::Contains("velocity_m_per_s"));
  reply = axis.move_to(s.soft_limit_max_m + 0.005, {0.02, 1.0, 1000.0});
  CHECK_FALSE(reply.accepted());
  CHECK_THAT(reply.text(), Catch::Contains("restricted mode"));
  // Accepted: back inside at reduced speed; the mode ends inside.
  const double slow = s.recovery_velocity_fraction * s.motion_limits.velocity_m_per_s;
  reply = axis.move_to(0.1, {slow, 1.0, 1000.0});
  INFO(reply.text());
  REQUIRE(reply.accepted());
  axis.daemon.run_until_idle(20000);
  axis.daemon.run_cycles(300);
  REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
  CHECK_FALSE(axis.daemon.cycle().mailbox().restricted());
  CHECK_FALSE(axis.record().restricted);
  CHECK(std::abs(axis.motor().truth().position_m - 0.1) < 1e-4);
  // Normal again: a brisk move is accepted.
  CHECK(axis.move_to(0.0, {0.5, 10.0, 1000.0}).accepted());
  axis.daemon.run_until_idle(20000);
  CHECK(axis.daemon.cycle().status().state == ServoState::kEnabled);
}

TEST_CASE("restricted mode: moving farther out latches 202 again, far outside it is not offered", "[daemon][stops][faults]") {
  auto config = test::ideal_plant_config();
  config.servo.recovery_margin_m = 0.01;  // the end stop is 20 mm beyond the soft limit
  Axis axis(config);
  const auto& s = axis.settings();
  axis.motor().push_to(s.soft_limit_min_m - 0.005);
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  (void)axis.daemon.take_replies();
  test::command(axis.daemon, Kind::kEnable, 5);
  REQUIRE(axis.daemon.cycle().mailbox().restricted());
  // Pushed 3 mm farther out (more than the following-error limit): 202 again.
  axis.motor().push_to(s.soft_limit_min_m - 0.008);
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  CHECK(axis.daemon.cycle().status().fault == Fault::kPositionOutOfRange);
  CHECK_FALSE(axis.daemon.cycle().mailbox().restricted());
  // Beyond recovery_margin_m: enable stays refused.
  axis.motor().push_to(s.soft_limit_min_m - s.recovery_margin_m - 0.001);
  axis.daemon.run_cycles(5);
  (void)axis.daemon.take_replies();
  test::command(axis.daemon, Kind::kEnable, 5);
  const auto replies = axis.daemon.take_replies();
  REQUIRE(replies.size() == 1);
  CHECK_FALSE(replies[0].accepted());
  CHECK(axis.daemon.cycle().status().state == ServoState::kFault);
}
