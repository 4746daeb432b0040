#pragma once
// A command to the servo daemon: one fixed-size type and one kind enum from
// the LCM message (servo_command_t, checked by telemetry::to_command) through
// ServoDaemon::submit into the cycle's command queue. kCommandRoutes says for
// every kind who answers it: the cycle (queued, answered with the cycle's
// decision a cycle later), the daemon (files and planning, answered at once) or
// the command authority (take and release control).

#include <array>
#include <cstddef>
#include <cstdint>

#include "daemon/control/position_controller.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/servo/cycle_record.hpp"
#include "daemon/servo/fixed_text.hpp"
#include "daemon/servo/tuning.hpp"

namespace clm::servo {

/// servo_command_t.command: the values are those of the LCM constants.
enum class CommandKind : std::int8_t {
  kEnable = 1,
  kDisable = 2,
  kClearFault = 3,
  kMoveTo = 4,
  kRunProgram = 5,
  kSetCommutation = 6,
  kSetExperiment = 7,
  kLoadCalibration = 8,
  kLoadModel = 9,
  kStop = 10,
  kLoadFeedforward = 11,
  kTakeControl = 12,     ///< command authority (daemon/servod/command_gate.hpp)
  kReleaseControl = 13,  ///< command authority (daemon/servod/command_gate.hpp)
  kQuickStop = 14,       ///< stop within the quick-stop limits (ServoCycle::quick_stop)
  kJog = 15,             ///< move at a velocity while repeated (ServoCycle::post_jog, renew_jog)
  kGetParameter = 16,    ///< the value of a run-time parameter (daemon/servod/parameters.hpp)
  kSetParameter = 17,    ///< change a run-time parameter at standstill (ServoCycle::apply_tuning)
};
inline constexpr int kCommandKinds = 17;

/// True when `code` is a CommandKind value (1..kCommandKinds).
constexpr bool is_command_kind(int code) noexcept { return code >= 1 && code <= kCommandKinds; }

/// Who answers a command.
enum class AnsweredBy : std::uint8_t {
  kCycle,   ///< queued for the cycle; answered with its decision (ServoDaemon::take_replies)
  kDaemon,  ///< reads files or plans on the caller's thread; answered by ServoDaemon::submit
  kAuthority,  ///< who commands the axis: answered by the command gate (daemon/servod/command_gate.hpp), never submitted
};

struct CommandRoute {
  CommandKind kind;
  const char* name;  ///< as in servo_command_t, lower case
  AnsweredBy answered_by;
};

/// Every kind, in the order of its value. load_feedforward reads its file on
/// the caller's thread, but its parameters go through the cycle's queue;
/// set_parameter is validated on the caller's thread, then goes there too.
inline constexpr std::array<CommandRoute, kCommandKinds> kCommandRoutes{{
    {CommandKind::kEnable, "enable", AnsweredBy::kCycle},
    {CommandKind::kDisable, "disable", AnsweredBy::kCycle},
    {CommandKind::kClearFault, "clear_fault", AnsweredBy::kCycle},
    {CommandKind::kMoveTo, "move_to", AnsweredBy::kDaemon},
    {CommandKind::kRunProgram, "run_program", AnsweredBy::kDaemon},
    {CommandKind::kSetCommutation, "set_commutation", AnsweredBy::kCycle},
    {CommandKind::kSetExperiment, "set_experiment", AnsweredBy::kCycle},
    {CommandKind::kLoadCalibration, "load_calibration", AnsweredBy::kDaemon},
    {CommandKind::kLoadModel, "load_model", AnsweredBy::kDaemon},
    {CommandKind::kStop, "stop", AnsweredBy::kCycle},
    {CommandKind::kLoadFeedforward, "load_feedforward", AnsweredBy::kCycle},
    {CommandKind::kTakeControl, "take_control", AnsweredBy::kAuthority},
    {CommandKind::kReleaseControl, "release_control", AnsweredBy::kAuthority},
    {CommandKind::kQuickStop, "quick_stop", AnsweredBy::kCycle},
    {CommandKind::kJog, "jog", AnsweredBy::kDaemon},
    {CommandKind::kGetParameter, "get_parameter", AnsweredBy::kDaemon},
    {CommandKind::kSetParameter, "set_parameter", AnsweredBy::kCycle},
}};

constexpr bool routes_in_order() noexcept {
  for (std::size_t i = 0; i < kCommandRoutes.size(); ++i) {
    if (static_cast<std::size_t>(kCommandRoutes[i].kind) != i + 1) return false;
  }
  return true;
}
static_assert(routes_in_order(), "kCommandRoutes[k] must describe the kind of value k + 1");

/// The route of `kind` (a valid CommandKind).
constexpr const CommandRoute& route(CommandKind kind) noexcept {
  return kCommandRoutes[static_cast<std::size_t>(kind) - 1];
}
/// True for the kinds the cycle answers (see AnsweredBy).
constexpr bool answered_by_cycle(CommandKind kind) noexcept { return route(kind).answered_by == AnsweredBy::kCycle; }

/// Stop, quick stop and disable: obeyed from anyone who names the axis, on a
/// path of their own that nothing else can fill (docs/servod.md, "Command
/// authority"). The cycle obeys each without condition (its answer is always
/// accepted), and obeying one twice changes nothing.
constexpr bool is_safety_command(CommandKind kind) noexcept {
  return kind == CommandKind::kStop || kind == CommandKind::kQuickStop || kind == CommandKind::kDisable;
}

/// A command; only the fields of `kind` are meaningful. Fixed size: the
/// cycle's queue carries it as it is.
struct Command {
  std::int64_t utime = 0;     ///< sender's wall-clock time [µs since the UNIX epoch]
  std::int64_t sequence = 0;  ///< echoed in the reply
  FixedText<33> axis;         ///< the axis it is for (daemon/servod/command_gate.hpp)
  std::int64_t session = 0;   ///< the daemon run it is for
  std::int64_t client = 0;    ///< the sender; echoed in the reply
  CommandKind kind = CommandKind::kStop;
  double target_m = 0.0;                                  ///< kMoveTo [m]
  control::MotionLimits limits{0.1, 1.0, 1000.0};         ///< kMoveTo, kJog (velocity: its size)
  double jog_velocity_m_per_s = 0.0;                      ///< kJog: signed velocity [m/s], + towards soft_limit_max_m
  PathText program;                                       ///< kRunProgram: program file
  /// kSetCommutation: the law; kSetExperiment: kExperiment; kLoadModel: the
  /// law it loads into (pgnn or spline; any other value: the model file's
  /// `kind:` chooses, as for commands from LCM, which have no such field).
  CommutationMode commutation = CommutationMode::kOriginal;
  int coil_set = 0;                                       ///< kSetExperiment: 1..L
  double delta_rad = 0.0;                                 ///< kSetExperiment [rad]
  PathText path;                                          ///< kLoadCalibration, kLoadModel, kLoadFeedforward
  /// kLoadFeedforward: read from `path` by ServoDaemon::submit; with an empty
  /// path (in-process callers only) used as given.
  control::FeedforwardParameters feedforward{};
  FixedText<48> parameter;  ///< kGetParameter, kSetParameter: its name, e.g. "control.bandwidth_hz"
  double value = 0.0;       ///< kSetParameter: the new value, in the parameter's unit
  /// kSetParameter: every run-time setting with the change, made by
  /// ServoDaemon::submit from `parameter` and `value`.
  Tuning tuning{};
};

}  // namespace clm::servo
