// Every fault of the safety item, provoked on the in-process simulated motor
// through the bus-side injection or the configuration. Each must latch with
// the right reason and put zero magnitudes with enable cleared on the bus in
// the cycle the fault was found (faults reported between cycles: the next
// cycle's frames), and in every cycle after until clear_fault; a fault whose
// reaction is a quick stop (servo::kFaultReactions), found while the axis
// moves, first brakes it under position control and is safe from the end of
// that stop on (test_stops.cpp covers every kind at full speed); then
// clear_fault → disabled → enable drives again. The expectations are checked
// on what the drive received (the frames decoded with the protocol's
// decoder, the simulated drive's status and currents), never on the cycle's
// own record alone.
#include <catch2/catch.hpp>
#include <cmath>

#include "daemon/control/stop_profile.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "drivers/sim/in_process_bus.hpp"
#include "drivers/sim/motor.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::Fault;
using servo::ServoState;

namespace {

/// The default daemon (or `config`) with the axis enabled, holding at the
/// centre of the stroke.
struct EnabledAxis {
  explicit EnabledAxis(const servod::ServodConfig& config = test::ideal_plant_config()) : wired(config), daemon(wired.daemon) {
    daemon.run_cycles(10);
    test::command(daemon, Kind::kEnable, 20);
    REQUIRE(daemon.cycle().status().state == ServoState::kEnabled);
    test::require_driving_output(wired);
  }
  /// Algorithms 1 and 2's mode at standstill: coil set 1 at Δ = 0.
  void start_experiment() {
    servo::Command experiment;
    experiment.kind = Kind::kSetExperiment;
    experiment.coil_set = 1;
    REQUIRE(daemon.submit(experiment).accepted());
    daemon.run_cycles(2);
    REQUIRE(daemon.cycle().status().mode == servo::CommutationMode::kExperiment);
  }
  sim::Injection& injection() { return wired.in_process_bus()->injection(); }
  sim::SimulatedMotor& motor() { return *wired.simulated_motor(); }
  const servo::CycleCounters& counters() { return daemon.cycle().status().counters; }
  int limit() const { return daemon.config().servo.missing_frame_limit; }

  void move_to(double target_m, control::MotionLimits limits) {
    servo::Command move;
    move.kind = Kind::kMoveTo;
    move.target_m = target_m;
    move.limits = limits;
    REQUIRE(daemon.submit(move).accepted());
  }

  /// The fault latched as `expected` and the last cycle's output is safe;
  /// `more` further cycles keep it latched and safe.
  void require_latched(Fault expected, bool frames_reached_drive = true, int more = 20) {
    INFO("fault " << servo::describe(daemon.cycle().status().fault));
    REQUIRE(daemon.cycle().status().state == ServoState::kFault);
    REQUIRE(daemon.cycle().status().fault == expected);
    test::require_safe_output(wired, frames_reached_drive);
    for (int k = 0; k < more; ++k) {
      daemon.run_cycles(1);
      REQUIRE(daemon.cycle().status().state == ServoState::kFault);
      REQUIRE(daemon.cycle().status().fault == expected);
      test::require_safe_output(wired);
    }
  }

  /// The fault latched as `expected` while the axis moved, and its reaction
  /// (servo::kFaultReactions) is a quick stop: the cycle of the fault still
  /// drives, the reference brakes within the quick-stop limits and comes to
  /// rest in the planned time, the fault stays `expected` throughout; then the
  /// output is safe (require_latched).
  void require_quick_stop_reaction(Fault expected) {
    REQUIRE(servo::reaction(expected) == servo::FaultReaction::kQuickStop);
    REQUIRE(daemon.cycle().status().state == ServoState::kFault);
    REQUIRE(daemon.cycle().status().fault == expected);
    REQUIRE(daemon.cycle().status().fault_reaction_running);
    test::require_driving_output(wired);
    const auto& s = daemon.config().servo;
    const auto& r = daemon.cycle().record();
    const auto planned = control::StopProfile::plan({r.r_m, r.r_dot_m_per_s, r.r_ddot_m_per_s2, 0.0},
                                                    s.quick_stop_limits);
    const auto max_cycles = static_cast<int>(std::ceil(planned.duration_s() / s.period_s)) + 2;
    int cycles = 0;
    while (daemon.cycle().status().fault_reaction_running) {
      daemon.run_cycles(1);
      REQUIRE(++cycles <= max_cycles);
      REQUIRE(daemon.cycle().status().state == ServoState::kFault);
      REQUIRE(daemon.cycle().status().fault == expected);
      CHECK(std::abs(daemon.cycle().record().r_ddot_m_per_s2) <= s.quick_stop_limits.deceleration_m_per_s2 + 1e-9);
    }
    CHECK(daemon.cycle().record().r_dot_m_per_s == 0.0);
  }

  /// clear_fault → disabled (one cycle asks the drive to clear too) → enable
  /// drives the axis again, and it stays so.
  void require_recovers() {
    (void)daemon.take_replies();
    REQUIRE(test::command(daemon, Kind::kEnable).accepted());  // queued
    CHECK(daemon.cycle().status().state == ServoState::kFault);
    const auto replies = daemon.take_replies();  // executed: refused while latched
    REQUIRE(replies.size() == 1);
    CHECK_FALSE(replies[0].accepted());
    CHECK(replies[0].result == servo::CommandResult::kRejectedFault);
    CHECK(replies[0].text() == "rejected: a fault is latched, clear it first");
    test::command(daemon, Kind::kClearFault);
    REQUIRE(daemon.cycle().status().state == ServoState::kDisabled);
    CHECK(daemon.cycle().status().fault == Fault::kNone);
    const auto clearing = test::sent_setpoints(wired);
    REQUIRE(clearing.complete);
    CHECK(clearing.command.clear_fault);
    CHECK_FALSE(clearing.command.enable);
    CHECK(clearing.all_magnitudes_zero());
    daemon.run_cycles(5);
    REQUIRE(daemon.cycle().status().state == ServoState::kDisabled);
    CHECK_FALSE(test::sent_setpoints(wired).command.clear_fault);
    CHECK_FALSE(wired.simulated_motor()->status().fault());
    test::command(daemon, Kind::kEnable);
    REQUIRE(daemon.cycle().status().state == ServoState::kEnabled);
    test::require_driving_output(wired);
    for (int k = 0; k < 200; ++k) {
      daemon.run_cycles(1);
      INFO("cycle " << k << " after enable: " << servo::describe(daemon.cycle().status().fault));
      REQUIRE(daemon.cycle().status().state == ServoState::kEnabled);
    }
    test::require_driving_output(wired);
    CHECK_FALSE(wired.simulated_motor()->status().fault());
  }

  servod::WiredAxis wired;  ///< the daemon and the simulated motor and bus it runs on
  servod::ServoDaemon& daemon;
};

/// Limits of a brisk move: 0.3 m/s, 10 m/s² (150 N on the 15 kg translator).
constexpr control::MotionLimits kBrisk{0.3, 10.0, 1000.0};

}  // namespace

TEST_CASE("encoder frames missing: one and limit-1 ride through, the limit latches kEncoderFrameMissing",
          "[daemon][faults]") {
  EnabledAxis axis;
  const int limit = axis.limit();
  REQUIRE(limit >= 2);
  for (const int n : {1, limit - 1}) {
    const auto missing = axis.counters().frames_missing;
    axis.injection().drop_drive_frames = n;
    for (int k = 0; k < n + 50; ++k) {
      axis.daemon.run_cycles(1);
      REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
      test::require_driving_output(axis.wired);
    }
    CHECK(axis.counters().frames_missing - missing == n);
  }
  axis.injection().drop_drive_frames = limit;
  CHECK(test::run_until_fault(axis.daemon, 50) == limit);
  axis.require_latched(Fault::kEncoderFrameMissing);
  axis.require_recovers();
}

TEST_CASE("force-sensor frames missing in an experiment: limit-1 ride through, the limit latches kForceFrameMissing",
          "[daemon][faults]") {
  EnabledAxis axis;
  axis.start_experiment();
  const int limit = axis.limit();
  for (const int n : {1, limit - 1}) {
    const auto missing = axis.counters().frames_missing;
    axis.injection().drop_force_frames = n;
    for (int k = 0; k < n + 50; ++k) {
      axis.daemon.run_cycles(1);
      REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
    }
    CHECK(axis.counters().frames_missing - missing == n);
  }
  axis.injection().drop_force_frames = limit;
  CHECK(test::run_until_fault(axis.daemon, 50) == limit);
  axis.require_latched(Fault::kForceFrameMissing);
  axis.require_recovers();
}

TEST_CASE("force-sensor frames missing in service: a warning with its reason, never a fault, that clears after "
          "missing_frame_limit good cycles",
          "[daemon][faults][force_sensor]") {
  EnabledAxis axis;
  const int limit = axis.limit();
  axis.injection().drop_force_frames = 1000;
  for (int k = 0; k < limit + 5; ++k) {
    axis.daemon.run_cycles(1);
    REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
    test::require_driving_output(axis.wired);
    // No measurement, no numbers: the record says so and carries zero.
    CHECK_FALSE(axis.daemon.cycle().record().force_measured);
    CHECK(axis.daemon.cycle().record().Fy_N == 0.0);
    CHECK(axis.daemon.cycle().status().force_sensor_warning == (k + 1 >= limit ? Fault::kForceFrameMissing : Fault::kNone));
  }
  CHECK(axis.counters().force_sensor_losses == 1);
  // An experiment measures with the sensor: refused while it is lost.
  test::require_experiment_refused_for_the_sensor(axis.daemon);
  // Frames again: measured at once, healthy after `limit` good cycles.
  axis.injection().drop_force_frames = 0;
  int good = 0;
  for (int k = 0; k < limit + 3 && good < limit; ++k) {
    axis.daemon.run_cycles(1);
    if (!axis.daemon.cycle().record().force_measured) continue;
    ++good;
    CHECK(axis.daemon.cycle().status().force_sensor_warning == (good >= limit ? Fault::kNone : Fault::kForceFrameMissing));
  }
  CHECK(good == limit);
  CHECK(axis.daemon.cycle().status().force_sensor_warning == Fault::kNone);
  CHECK(axis.counters().force_sensor_losses == 1);
  CHECK(axis.daemon.cycle().status().state == ServoState::kEnabled);
}

TEST_CASE("late encoder frames are counted and ride through below the limit, late at the limit latches",
          "[daemon][faults]") {
  EnabledAxis axis;
  const int limit = axis.limit();
  for (const int n : {1, limit - 1}) {
    const auto late = axis.counters().frames_late;
    axis.injection().delay_drive_frames = n;
    for (int k = 0; k < n + 50; ++k) {
      axis.daemon.run_cycles(1);
      REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
      test::require_driving_output(axis.wired);
    }
    CHECK(axis.counters().frames_late - late == n);  // each arrived, a cycle late, and was not used
  }
  // A frame one cycle late in every cycle: the cycle never has a timely
  // position, so this must end like missing frames.
  axis.injection().delay_drive_frames = 1000;
  CHECK(test::run_until_fault(axis.daemon, 50) == limit);
  axis.require_latched(Fault::kEncoderFrameMissing);
  axis.injection().delay_drive_frames = 0;
  axis.daemon.run_cycles(2);  // the last held-back frame arrives late
  axis.require_recovers();
}

TEST_CASE("duplicated encoder frames are counted and ride through", "[daemon][faults]") {
  EnabledAxis axis;
  axis.move_to(0.02, kBrisk);
  axis.injection().duplicate_drive_frames = 25;
  for (int k = 0; k < 100; ++k) {
    axis.daemon.run_cycles(1);
    REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
  }
  CHECK(axis.counters().frames_duplicate == 25);
  CHECK(axis.counters().frames_missing == 0);
  axis.daemon.run_until_idle(5000);
  axis.daemon.run_cycles(500);  // settle
  REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
  CHECK(std::abs(axis.motor().truth().position_m - 0.02) < 1e-5);
}

TEST_CASE("a drive alive-counter jump latches kEncoderAliveJump at once", "[daemon][faults]") {
  EnabledAxis axis;
  axis.injection().skip_drive_alive = 7;
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  axis.require_latched(Fault::kEncoderAliveJump);
  axis.require_recovers();
}

TEST_CASE("a force-sensor alive-counter jump latches kForceAliveJump at once in an experiment, and is a warning in "
          "service",
          "[daemon][faults][force_sensor]") {
  SECTION("experiment") {
    EnabledAxis axis;
    axis.start_experiment();
    axis.injection().skip_force_alive = 3;
    CHECK(test::run_until_fault(axis.daemon, 5) == 1);
    axis.require_latched(Fault::kForceAliveJump);
    axis.require_recovers();
  }
  SECTION("service") {
    EnabledAxis axis;
    axis.injection().skip_force_alive = 3;
    axis.daemon.run_cycles(1);
    CHECK(axis.daemon.cycle().status().force_sensor_warning == Fault::kForceAliveJump);
    axis.daemon.run_cycles(axis.limit());
    CHECK(axis.daemon.cycle().status().force_sensor_warning == Fault::kNone);
    CHECK(axis.daemon.cycle().status().state == ServoState::kEnabled);
    CHECK(axis.counters().force_sensor_losses == 1);
    test::require_driving_output(axis.wired);
  }
}

TEST_CASE("alive counters that skip exactly the frames missed are no jump", "[daemon][faults]") {
  EnabledAxis axis;
  axis.injection().drop_drive_frames = axis.limit() - 1;
  axis.injection().drop_force_frames = axis.limit() - 1;
  axis.daemon.run_cycles(100);
  CHECK(axis.daemon.cycle().status().state == ServoState::kEnabled);
  // A late frame followed by the timely one: both in sequence.
  axis.injection().delay_drive_frames = 1;
  axis.daemon.run_cycles(100);
  CHECK(axis.daemon.cycle().status().state == ServoState::kEnabled);
  CHECK(axis.counters().frames_late == 1);
}

TEST_CASE("drive frames with a wrong DLC are rejected and ride through below the limit, at it kFrameRejected",
          "[daemon][faults]") {
  EnabledAxis axis;
  const int limit = axis.limit();
  for (const int n : {1, limit - 1}) {
    const auto rejected = axis.counters().frames_rejected;
    axis.injection().wrong_dlc_drive_frames = n;
    for (int k = 0; k < n + 50; ++k) {
      axis.daemon.run_cycles(1);
      REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
      test::require_driving_output(axis.wired);
    }
    CHECK(axis.counters().frames_rejected - rejected == n);
  }
  axis.injection().wrong_dlc_drive_frames = limit;
  CHECK(test::run_until_fault(axis.daemon, 50) == limit);
  axis.require_latched(Fault::kFrameRejected);
  axis.require_recovers();
}

TEST_CASE("a corrupted position (0x7fffffff nm = 2.147 m) latches kPositionOutOfRange at once", "[daemon][faults]") {
  EnabledAxis axis;
  axis.injection().corrupt_position_frames = 1;
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  CHECK(axis.daemon.cycle().record().y_m == Approx(2147483647e-9));
  CHECK(std::abs(axis.motor().truth().position_m) < 1e-3);  // the axis itself did not move
  axis.require_latched(Fault::kPositionOutOfRange);
  axis.require_recovers();
}

TEST_CASE("a following error above the configured limit latches kFollowingError at its first cycle",
          "[daemon][faults]") {
  // 150 N of acceleration force over k_p ≈ 0.557·m·ω_c² = 5.3e5 N/m: the
  // brisk move lags by ~0.3 mm, six times this limit; holding lags by far less.
  auto config = test::ideal_plant_config();
  config.servo.following_error_limit_m = 50e-6;
  EnabledAxis axis(config);
  axis.move_to(0.05, kBrisk);
  double previous_error_m = 0.0;
  std::int64_t cycles = 0;
  while (axis.daemon.cycle().status().state == ServoState::kEnabled) {
    const auto& record = axis.daemon.cycle().record();
    previous_error_m = record.r_m - axis.motor().truth().position_m;
    axis.daemon.run_cycles(1);
    REQUIRE(++cycles < 2000);
  }
  // Independent of the record: the encoder is the truth quantised to 0.1 µm.
  const double error_m =
      axis.daemon.cycle().record().r_m - axis.motor().truth().position_m;
  INFO("error at the fault " << error_m << " m, one cycle before " << previous_error_m << " m");
  CHECK(std::abs(error_m) > 50e-6 - 1e-7);
  CHECK(std::abs(previous_error_m) <= 50e-6 + 1e-7);
  axis.require_quick_stop_reaction(Fault::kFollowingError);
  axis.require_latched(Fault::kFollowingError);
  axis.require_recovers();
}

TEST_CASE("a position outside the soft limits latches kPositionOutOfRange, enabled or not", "[daemon][faults]") {
  EnabledAxis axis;
  const double soft_max_m = axis.daemon.config().servo.soft_limit_max_m;
  // The translator pushed past the soft limit (inside the end stops).
  axis.motor().push_to(soft_max_m + 0.005);
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  CHECK(axis.motor().truth().position_m > soft_max_m);
  axis.require_latched(Fault::kPositionOutOfRange);
  // Still outside: clearing re-latches at once.
  test::command(axis.daemon, Kind::kClearFault);
  CHECK(axis.daemon.cycle().status().fault == Fault::kPositionOutOfRange);
  // Back inside, it recovers.
  axis.motor().push_to(0.0);
  axis.daemon.run_cycles(2);
  axis.require_recovers();

  // Disabled axis moved outside by hand: the fault latches all the same.
  test::command(axis.daemon, Kind::kDisable);
  REQUIRE(axis.daemon.cycle().status().state == ServoState::kDisabled);
  axis.motor().push_to(axis.daemon.config().servo.soft_limit_min_m - 0.005);
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  axis.require_latched(Fault::kPositionOutOfRange);
}

TEST_CASE("a force demand saturated longer than the limit latches kForceSaturated and the limit holds meanwhile",
          "[daemon][faults]") {
  // A push 50 N beyond the force limit against a gentle move (1 m/s^2): the
  // loop saturates. Inside the safe envelope, so that only the saturation trips: a
  // following-error limit of 20 mm (wider than the push makes in the 50 ms of
  // saturation_time_limit_s), the soft limits 40 mm inside the stroke.
  auto config = test::ideal_plant_config();
  config.servo.following_error_limit_m = 0.02;
  config.servo.soft_limit_min_m = config.servo.machine.stroke_min_m + 0.04;
  config.servo.soft_limit_max_m = config.servo.machine.stroke_max_m - 0.04;
  EnabledAxis axis(config);
  REQUIRE(axis.daemon.cycle().status().mode == servo::CommutationMode::kOriginal);
  const double force_limit_N = config.servo.force_limit_N;
  axis.move_to(0.05, {0.3, 1.0, 1000.0});
  axis.motor().set_disturbance_force_N(-(force_limit_N + 50.0));
  int saturated_cycles = 0;
  int max_saturated_run = 0;
  while (axis.daemon.cycle().status().state == ServoState::kEnabled) {
    axis.daemon.run_cycles(1);
    if (axis.daemon.cycle().status().state != ServoState::kEnabled) break;
    // The drive's own law shares F* equally: the magnitudes on the bus sum to
    // F*, so |Σ| shows the limit holding without trusting the record.
    const double sum_N = test::sent_setpoints(axis.wired).magnitude_sum_N();
    CHECK(std::abs(sum_N) <= force_limit_N + 3 * can::kMagnitudeLsb_N);
    saturated_cycles = std::abs(sum_N) >= force_limit_N - 3 * can::kMagnitudeLsb_N ? saturated_cycles + 1 : 0;
    max_saturated_run = std::max(max_saturated_run, saturated_cycles);
    REQUIRE(axis.daemon.cycle().status().counters.cycles < 5000);
  }
  // The fault cycle is the one whose saturation reaches the time limit (the
  // quick stop of its reaction starts there): the limit in cycles, give or
  // take the rounding of the accumulated time.
  const double limit_cycles = config.servo.saturation_time_limit_s / config.servo.period_s;
  INFO("saturated for " << saturated_cycles << " cycles before the fault");
  CHECK(saturated_cycles + 1 >= limit_cycles);
  CHECK(saturated_cycles + 1 <= limit_cycles + 1);
  axis.motor().set_disturbance_force_N(0.0);
  axis.require_quick_stop_reaction(Fault::kForceSaturated);
  axis.require_latched(Fault::kForceSaturated);
  axis.require_recovers();
}

TEST_CASE("a wake-up gap up to stall_limit_s rides through, a longer one latches kLoopStalled with a quick stop",
          "[daemon][faults]") {
  EnabledAxis axis;
  const double limit_s = axis.daemon.config().servo.stall_limit_s;
  axis.move_to(0.05, kBrisk);
  axis.daemon.run_cycles(100);  // moving
  // The virtual loop never stalls: the cycles start as after a gap.
  axis.daemon.run_cycle_after(limit_s, false);
  REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
  axis.daemon.run_cycle_after(limit_s * 1.01, false);
  axis.require_quick_stop_reaction(Fault::kLoopStalled);
  axis.require_latched(Fault::kLoopStalled);
  axis.require_recovers();
}

TEST_CASE("overruns: limit-1 in a row ride through, the limit latches kRepeatedOverruns", "[daemon][faults]") {
  EnabledAxis axis;
  const int limit = axis.daemon.config().servo.overrun_limit;
  // The virtual loop never overruns: the cycles start as after an overrun.
  for (int k = 0; k < limit - 1; ++k) axis.daemon.run_cycle_after(0.0, true);
  axis.daemon.run_cycle_after(0.0, false);
  REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
  for (int k = 0; k < limit; ++k) {
    REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
    axis.daemon.run_cycle_after(0.0, true);
  }
  CHECK(axis.daemon.cycle().status().fault == Fault::kRepeatedOverruns);
  CHECK(axis.counters().overruns == 2 * limit - 1);
  axis.daemon.run_cycles(1);
  axis.require_latched(Fault::kRepeatedOverruns);
  axis.require_recovers();
}

TEST_CASE("a drive watchdog trip is reported by the drive and latches kDriveWatchdog, clearing clears the drive",
          "[daemon][faults]") {
  EnabledAxis axis;
  const auto& protocol = axis.daemon.config().servo.protocol;
  const double watchdog_s = axis.motor().parameters().drive.watchdog_timeout_s;
  const auto cycles_lost = static_cast<int>(std::ceil(watchdog_s / axis.daemon.config().servo.period_s)) + 3;
  axis.injection().drop_setpoint_frames = cycles_lost * static_cast<int>(can::setpoint_frame_count(protocol.coil_sets));
  const auto cycles = test::run_until_fault(axis.daemon, cycles_lost + 10);
  INFO("fault after " << cycles << " cycles");
  // The drive faults first, and the cycle latches in the cycle its status word says so.
  CHECK(axis.motor().status().watchdog());
  CHECK(axis.motor().status().fault());
  CHECK(cycles == std::llround(watchdog_s / axis.daemon.config().servo.period_s));
  // The watchdog's own fault, not the drive's generic one it comes with.
  axis.require_latched(Fault::kDriveWatchdog, false);
  REQUIRE(axis.injection().drop_setpoint_frames == 0);
  axis.require_recovers();
}

TEST_CASE("CAN bus-off latches kBusOff in the cycle it is seen", "[daemon][faults]") {
  EnabledAxis axis;
  axis.injection().bus_state = drivers::BusState::kBusOff;
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  axis.require_latched(Fault::kBusOff);
  axis.injection().bus_state = drivers::BusState::kActive;
  axis.daemon.run_cycles(3);
  axis.require_latched(Fault::kBusOff, true, 3);  // latched until cleared, even with the bus back
  axis.require_recovers();
}

TEST_CASE("CAN error-passive latches kBusErrorPassive in the cycle it is seen", "[daemon][faults]") {
  EnabledAxis axis;
  axis.injection().bus_state = drivers::BusState::kErrorPassive;
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  axis.require_latched(Fault::kBusErrorPassive);
  axis.injection().bus_state = drivers::BusState::kActive;
  axis.require_recovers();
}

TEST_CASE("a failing send latches kSendFailed and zero setpoints go out as soon as the bus takes frames",
          "[daemon][faults]") {
  EnabledAxis axis;
  const double drive_time_s = axis.motor().truth().time_s;
  axis.injection().fail_sends = true;
  CHECK(test::run_until_fault(axis.daemon, 5) == 1);
  CHECK(axis.daemon.cycle().status().fault == Fault::kSendFailed);
  // Nothing reached the nodes (not even the SYNC): the drive did not step.
  CHECK(axis.motor().truth().time_s == drive_time_s);
  CHECK(test::sent_setpoints(axis.wired).frames == 0);
  axis.injection().fail_sends = false;
  axis.daemon.run_cycles(1);
  axis.require_latched(Fault::kSendFailed);
  axis.require_recovers();
}

TEST_CASE("a lost setpoint frame never makes the drive apply a mix of two cycles", "[daemon][faults]") {
  // Setpoints never outlive their cycle, on the drive's side either: a cycle
  // whose RPDOs did not all arrive is dropped at the next SYNC.
  EnabledAxis axis;
  axis.move_to(0.05, {0.15, 1.0, 1000.0});
  axis.daemon.run_cycles(200);  // moving: the setpoints change every cycle
  axis.injection().drop_setpoint_frames = 1;  // RPDO1 of the next cycle
  const auto& drive = axis.daemon.config().motor.drive;
  const double pole_pitch_m = axis.daemon.config().motor.pole_pitch_m;
  for (int k = 0; k < 20; ++k) {
    axis.daemon.run_cycles(1);
    REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
    if (k == 0) continue;  // the cycle whose set was incomplete: the drive keeps the last complete one
    // The currents the drive applies are those of this cycle's frames.
    const auto sent = test::sent_setpoints(axis.wired);
    const sim::TruthState truth = axis.motor().truth();
    for (int l = 0; l < sent.command.coil_sets; ++l) {
      const Eigen::Vector2d expected =
          drive_phase_currents(drive, sent.command.setpoints[static_cast<std::size_t>(l)], truth.position_m, pole_pitch_m);
      INFO("cycle " << k << " coil set " << l + 1);
      CHECK(truth.currents_A(2 * l) == Approx(expected.x()).margin(1e-9));
      CHECK(truth.currents_A(2 * l + 1) == Approx(expected.y()).margin(1e-9));
    }
  }
}

TEST_CASE("an experiment ends with a disable and with a fault: the next enable drives the service law",
          "[daemon][faults][experiment]") {
  EnabledAxis axis;
  // The service law is the configuration's, independent of the cycle's bookkeeping.
  const servo::CommutationMode service = axis.daemon.config().commutation.mode;
  REQUIRE(service != servo::CommutationMode::kExperiment);
  axis.start_experiment();
  SECTION("disable") {
    test::command(axis.daemon, Kind::kDisable, 2);
    INFO("commutation after disable: " << servo::name(axis.daemon.cycle().status().mode));
    CHECK(axis.daemon.cycle().status().state == ServoState::kDisabled);
    CHECK(axis.daemon.cycle().status().mode == service);
  }
  SECTION("fault") {
    axis.injection().drop_drive_frames = axis.limit();
    REQUIRE(test::run_until_fault(axis.daemon, 50) == axis.limit());
    INFO("commutation after the fault: " << servo::name(axis.daemon.cycle().status().mode));
    CHECK(axis.daemon.cycle().status().mode == service);
    test::command(axis.daemon, Kind::kClearFault, 2);
    REQUIRE(axis.daemon.cycle().status().state == ServoState::kDisabled);
  }
  test::command(axis.daemon, Kind::kEnable, 5);
  REQUIRE(axis.daemon.cycle().status().state == ServoState::kEnabled);
  INFO("commutation after enable: " << servo::name(axis.daemon.cycle().status().mode));
  CHECK(axis.daemon.cycle().status().mode == service);
  CHECK(axis.daemon.cycle().record().commutation == service);
  CHECK(axis.daemon.cycle().record().coil_set == 0);
  CHECK_FALSE(axis.daemon.cycle().status().mode_change_pending);
  test::require_driving_output(axis.wired);
}
