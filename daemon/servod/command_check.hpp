#pragma once
// What ServoDaemon::submit checks and completes in a command before acting on
// it, beyond the wire-level checks of telemetry::to_command. Non-real-time.
// The daemon itself reads the files of load_model and load_feedforward only
// through its file policy and loader (servo_daemon.hpp, docs/servod.md
// "Files") and calls this for the other kinds; the file reading here serves
// in-process callers that trust the path.

#include <string>

#include "daemon/control/trajectory.hpp"
#include "daemon/servo/command.hpp"
#include "daemon/servo/servo_cycle.hpp"

namespace clm::servod {

/// Checks and completes `command` in place. Returns "" when it can be carried
/// out, else the one-line reason: move_to whose limits are not positive;
/// set_commutation to experiment (set_experiment is the way there);
/// load_model whose file cannot be read or whose `kind:` is neither pgnn nor
/// spline, when the command names no law (the file's kind then chooses it);
/// load_feedforward whose file cannot be read or holds a non-finite parameter
/// (the parameters read go into command.feedforward; an empty path keeps the
/// parameters given).
std::string check_command(servo::Command& command);

/// "" when `limits` lie within `max` (velocity, acceleration, jerk), else the
/// reason, starting with `what` and naming the value and its limit.
std::string check_motion_limits(const std::string& what, const control::MotionLimits& limits,
                                const control::MotionLimits& max);

/// "" when a stop within settings.stop_limits, begun from the reference of any
/// cycle of `program` (sampled every settings.period_s), comes to rest within
/// the soft limits; else the reason with the time, state and rest position.
std::string check_stopping(const std::string& what, const control::MoveProgram& program,
                           const servo::ServoSettings& settings);

}  // namespace clm::servod
