#pragma once
// A move decided once: from the settings, the axis's present state and a
// move_to, run_program or jog, either the program the cycle is to run or the
// refusal, one line naming the value and the limit. Pure: no I/O, no threads,
// no clock; the daemon calls it with what the cycle reports, and the tests
// call it directly (tests/daemon/test_move_decision.cpp).
//
// Which stop admission guarantees: a move is admitted only when the ordinary
// stop (settings.stop_limits, the softer one) from the reference of every
// cycle of it comes to rest inside the soft limits, so that a STOP, and a
// jog's timeout, always rest inside. The cycle's approach guard
// (servo_cycle.cpp) is a last resort for what no admission saw (an axis
// running ahead of its reference, a program posted past this check) and
// stops with the harder quick stop (settings.quick_stop_limits, at least the
// stop's deceleration and jerk): its check of the reference does not fire on
// an admitted move, since the quick stop from a sample rests no farther than
// the stop admission checked from it.

#include <cstddef>
#include <optional>
#include <span>
#include <string>

#include "daemon/control/trajectory.hpp"
#include "daemon/servo/command.hpp"
#include "daemon/servo/servo_cycle.hpp"

namespace clm::servo {

/// A planned stop may rest this far beyond a soft limit (rounding of the stop
/// profile's closed forms): in admission (decide_move) and in the cycle's
/// approach guard alike.
inline constexpr double kStopTolerance_m = 1e-9;

/// What the cycle and the daemon report of the axis when a move is decided.
struct AxisSnapshot {
  ServoState state = ServoState::kDisabled;
  bool at_rest = true;            ///< no program, jog or stop under way, none waiting to start
  bool restricted = false;        ///< restricted mode (docs/servod.md, "Restricted mode")
  double hold_position_m = 0.0;   ///< where the axis holds: every move starts here [m]
  bool parameter_change_pending = false;  ///< the limits are about to change
  bool jog_running = false;       ///< a jog runs or waits to start
  double jog_velocity_m_per_s = 0.0;     ///< the running jog's signed velocity [m/s]
  control::MotionLimits jog_limits{0.0, 0.0, 0.0};  ///< the running jog's limits
};

/// run_program's content: the program file's start and steps.
struct ProgramSteps {
  double start_m = 0.0;
  std::span<const control::ProgramStep> steps;
};

/// The decision: a program to post (result kProgramPosted or kJogStarted), a
/// renewal of the running jog (kJogging, no program), or a refusal (a
/// kRejected* result with `detail` naming value and limit where there is one).
struct MoveDecision {
  CommandResult result = CommandResult::kRejectedInvalid;
  std::string detail;
  std::optional<control::MoveProgram> program;
};

/// Decides `command` (kMoveTo, kRunProgram with `program`, kJog; any other
/// kind is refused as kRejectedInvalid) against `settings` and `axis`:
/// - legality by the command table (check_legal: enabled, at rest; a jog's
///   repeat with the same velocity and limits renews the running jog);
/// - a parameter change on its way, restricted mode (only a move_to back
///   inside, at recovery_velocity_fraction of the velocity limit);
/// - every target inside the soft limits; every velocity, acceleration and
///   jerk at most settings.motion_limits;
/// - a stop within settings.stop_limits begun from the reference of any cycle
///   rests inside the soft limits (check_stopping).
/// The program starts at axis.hold_position_m; run_program first moves to
/// the file's start when the axis is elsewhere (with the first step's limits);
/// a jog ends following_error_limit_m short of the soft limit it heads for.
MoveDecision decide_move(const ServoSettings& settings, const AxisSnapshot& axis, const Command& command,
                         const ProgramSteps& program = {});

/// The program run_program runs from `hold_m`: a first move to `program.start_m`
/// when the axis holds elsewhere (with the first step's limits), then the steps.
control::MoveProgram program_from_hold(const ProgramSteps& program, double hold_m);

/// "" when `limits` lie within `max` (velocity, acceleration, jerk), else the
/// reason, starting with `what` and naming the value and its limit.
std::string check_motion_limits(const std::string& what, const control::MotionLimits& limits,
                                const control::MotionLimits& max);

/// Where find_stop_outside looked and what it found.
struct StopSearch {
  bool outside = false;                ///< a stop from `reference` rests outside the soft limits
  double t_s = 0.0;                    ///< program time of that reference [s] (when `outside`)
  control::ReferenceSample reference;  ///< program.sample(t_s) (when `outside`)
  double rest_m = 0.0;                 ///< where that stop rests [m] (when `outside`)
  std::size_t stops_planned = 0;       ///< stops planned (stopping_position_m calls) in the search
};

/// The earliest time, of those it evaluates, at which a stop within
/// settings.stop_limits begun from the reference of `program` comes to rest
/// outside the soft limits (beyond kStopTolerance_m), or `outside` false when
/// none does. Covers every instant of the program, at least every cycle
/// (k · settings.period_s), while planning few stops: where the program's
/// jerk and deceleration lie within the stop's (and the stop need not
/// reverse), the rest position moves one way only and is checked at the ends
/// of that stretch; elsewhere at every cycle and the stretch's end (the
/// argument: above find_stop_outside in move_decision.cpp).
StopSearch find_stop_outside(const control::MoveProgram& program, const ServoSettings& settings);

/// "" when a stop within settings.stop_limits, begun from the reference of any
/// cycle of `program`, comes to rest within the soft limits (kStopTolerance_m;
/// find_stop_outside); else the reason with the time, state and rest position.
std::string check_stopping(const std::string& what, const control::MoveProgram& program,
                           const ServoSettings& settings);

}  // namespace clm::servo
