#pragma once
// What ServoDaemon::submit checks and completes in a command before acting on
// it, beyond the wire-level checks of telemetry::to_command. Non-real-time.
// The daemon itself reads the files of load_model and load_feedforward only
// through its file policy and loader (servo_daemon.hpp, docs/servod.md
// "Files") and calls this for the other kinds; the file reading here serves
// in-process callers that trust the path. Moves are decided by
// servo::decide_move (daemon/servo/move_decision.hpp).

#include <string>

#include "daemon/servo/command.hpp"

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

}  // namespace clm::servod
