#pragma once
// A command to the servo daemon: one fixed-size type and one kind enum from
// the LCM message (servo_command_t, checked by telemetry::to_command) through
// ServoDaemon::submit into the cycle's command queue. kCommandRoutes is the
// one table of what a kind decides by itself: who answers it (the cycle, the
// daemon or the command authority), its class for the command authority, the
// file it reads, and the states in which it is legal. The command server, the
// daemon, the LCM conversion and the client (servod_client::needs_control)
// all read it.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "daemon/control/position_controller.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/servo/command_result.hpp"
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
  kQuickStop = 14,       ///< stop within the quick-stop limits (ServoCycle::execute)
  kJog = 15,             ///< move at a velocity while repeated (CycleMailbox::post_jog, renew_jog)
  kGetParameter = 16,    ///< the value of a run-time parameter (daemon/servod/parameters.hpp)
  kSetParameter = 17,    ///< change a run-time parameter at standstill (ServoCycle::execute)
  kRenewControl = 18,    ///< the holder's heartbeat: a deadman lease (daemon/servod/command_gate.hpp)
  kHome = 19,            ///< find the commutation and the reference (ServoCycle::execute; docs/servod.md, "Homing")
};
inline constexpr int kCommandKinds = 19;

/// True when `code` is a CommandKind value (1..kCommandKinds).
constexpr bool is_command_kind(int code) noexcept { return code >= 1 && code <= kCommandKinds; }

/// Who answers a command.
enum class AnsweredBy : std::uint8_t {
  kCycle,   ///< queued for the cycle; answered with its decision (ServoDaemon::take_replies)
  kDaemon,  ///< answered on the command thread by ServoDaemon::submit (get_parameter)
  kLoader,  ///< its file read on the loader thread; answered by ServoDaemon::take_replies once read
  kAuthority,  ///< who commands the axis: answered by the command gate (daemon/servod/command_gate.hpp), never submitted
};

/// What a command asks of the command authority (daemon/servod/command_gate.hpp).
enum class CommandClass : std::uint8_t {
  kSafety,          ///< stop, quick stop, disable: obeyed from any client
  kRead,            ///< changes nothing, answered for any client
  kTakeControl,
  kReleaseControl,
  kRenewControl,    ///< only from the holder; no sequence kept (a heartbeat from a thread of its own)
  kControlled,      ///< the sender must hold control
};

/// Whether a command reads a file (on the daemon's loader thread, through its
/// file policy: docs/servod.md "Files"), and which field names it.
enum class FileUse : std::uint8_t {
  kNone,
  kProgram,   ///< Command::program must name one
  kPath,      ///< Command::path must name one
  kPathOrValues,  ///< Command::path when not empty; in-process callers may give the values instead
};

/// The servo states in which a command is legal: a set of ServoState bits.
enum LegalStates : std::uint8_t {
  kInDisabled = 1u << static_cast<unsigned>(ServoState::kDisabled),
  kInEnabled = 1u << static_cast<unsigned>(ServoState::kEnabled),
  kInFault = 1u << static_cast<unsigned>(ServoState::kFault),
  kInAnyState = kInDisabled | kInEnabled | kInFault,
};

/// One row per command kind: everything decided about a kind by its kind alone.
/// A refusal is a CommandResult, whose describe() holds its words.
struct CommandRoute {
  CommandKind kind;
  const char* name;  ///< as in servo_command_t, lower case
  AnsweredBy answered_by;
  CommandClass command_class;
  FileUse file;
  const char* file_kind;  ///< what its file holds, for refusals and the log ("" without a file)
  std::uint8_t legal_in;  ///< LegalStates; outside them the daemon refuses it before anything else
  /// Only at rest: no program, jog or stop under way and none waiting to
  /// start. (A jog's repeat renews the running jog; starting one needs rest:
  /// decide_move, move_decision.hpp.)
  bool at_rest_only;
};

/// Every kind, in the order of its value. enable is legal with a fault
/// latched: the cycle decides (restricted mode, docs/servod.md). The cycle
/// also answers what the daemon decides or reads first: move_to, jog and
/// run_program (decided by servo::decide_move, answered once the cycle has
/// taken the program or said why not; run_program's file read first),
/// load_feedforward (its file read first) and set_parameter (validated first).
inline constexpr std::array<CommandRoute, kCommandKinds> kCommandRoutes{{
    // kind                            name                 answered by              class                           file                     its file        legal in      at rest
    {CommandKind::kEnable,           "enable",            AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kDisable,          "disable",           AnsweredBy::kCycle,      CommandClass::kSafety,          FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kClearFault,       "clear_fault",       AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kMoveTo,           "move_to",           AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kNone,          "",             kInEnabled,   true},
    {CommandKind::kRunProgram,       "run_program",       AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kProgram,       "program",      kInEnabled,   true},
    {CommandKind::kSetCommutation,   "set_commutation",   AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kSetExperiment,    "set_experiment",    AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kLoadCalibration,  "load_calibration",  AnsweredBy::kLoader,     CommandClass::kControlled,      FileUse::kPath,          "calibration",  kInAnyState,  false},
    {CommandKind::kLoadModel,        "load_model",        AnsweredBy::kLoader,     CommandClass::kControlled,      FileUse::kPath,          "model",        kInAnyState,  false},
    {CommandKind::kStop,             "stop",              AnsweredBy::kCycle,      CommandClass::kSafety,          FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kLoadFeedforward,  "load_feedforward",  AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kPathOrValues,  "feedforward",  kInAnyState,  false},
    {CommandKind::kTakeControl,      "take_control",      AnsweredBy::kAuthority,  CommandClass::kTakeControl,     FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kReleaseControl,   "release_control",   AnsweredBy::kAuthority,  CommandClass::kReleaseControl,  FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kQuickStop,        "quick_stop",        AnsweredBy::kCycle,      CommandClass::kSafety,          FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kJog,              "jog",               AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kNone,          "",             kInEnabled,   false},
    {CommandKind::kGetParameter,     "get_parameter",     AnsweredBy::kDaemon,     CommandClass::kRead,            FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kSetParameter,     "set_parameter",     AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kNone,          "",             kInAnyState,  true},
    {CommandKind::kRenewControl,     "renew_control",     AnsweredBy::kAuthority,  CommandClass::kRenewControl,    FileUse::kNone,          "",             kInAnyState,  false},
    {CommandKind::kHome,             "home",              AnsweredBy::kCycle,      CommandClass::kControlled,      FileUse::kNone,          "",             kInDisabled | kInEnabled,  true},
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

/// move_to, run_program and jog: decided by servo::decide_move and offered
/// to the cycle as a program (CycleMailbox), answered once the cycle has
/// taken it or said why not.
constexpr bool is_move(CommandKind kind) noexcept {
  return kind == CommandKind::kMoveTo || kind == CommandKind::kRunProgram || kind == CommandKind::kJog;
}
/// Stop, quick stop and disable: obeyed from anyone who names the axis, on a
/// path of their own that nothing else can fill (docs/servod.md, "Command
/// authority"). The cycle obeys each without condition (its answer is always
/// accepted), and obeying one twice changes nothing.
constexpr bool is_safety_command(CommandKind kind) noexcept {
  return route(kind).command_class == CommandClass::kSafety;
}

/// The table's verdict on `kind` in servo state `state` with the axis at rest
/// or not: kAccepted, or the refusal (kRejectedFault, kRejectedDisabled,
/// kRejectedBusy).
constexpr CommandResult check_legal(CommandKind kind, ServoState state, bool at_rest) noexcept {
  const CommandRoute& r = route(kind);
  if ((r.legal_in & (1u << static_cast<unsigned>(state))) == 0) {
    return state == ServoState::kFault ? CommandResult::kRejectedFault : CommandResult::kRejectedDisabled;
  }
  if (r.at_rest_only && !at_rest) return CommandResult::kRejectedBusy;
  return CommandResult::kAccepted;
}

/// A command; only the fields of `kind` are meaningful. Fixed size: the
/// cycle's queue carries it as it is.
struct Command {
  std::int64_t utime = 0;     ///< sender's wall-clock time [µs since the UNIX epoch]
  std::int64_t sequence = 0;  ///< echoed in the reply
  FixedText<33> axis{};         ///< the axis it is for (daemon/servod/command_gate.hpp)
  std::int64_t session = 0;   ///< the daemon run it is for
  std::int64_t client = 0;    ///< the sender; echoed in the reply
  CommandKind kind = CommandKind::kStop;
  double target_m = 0.0;                                  ///< kMoveTo [m]
  control::MotionLimits limits{0.1, 1.0, 1000.0};         ///< kMoveTo, kJog (velocity: its size)
  double jog_velocity_m_per_s = 0.0;                      ///< kJog: signed velocity [m/s], + towards soft_limit_max_m
  PathText program{};                                       ///< kRunProgram: program file
  /// kSetCommutation: the law; kSetExperiment: kExperiment; kLoadModel: the
  /// law it loads into (pgnn or spline; any other value: the model file's
  /// `kind:` chooses, as for commands from LCM, which have no such field).
  CommutationMode commutation = CommutationMode::kOriginal;
  int coil_set = 0;                                       ///< kSetExperiment: 1..L
  double delta_rad = 0.0;                                 ///< kSetExperiment [rad]
  PathText path{};                                          ///< kLoadCalibration, kLoadModel, kLoadFeedforward
  /// kLoadFeedforward: read from `path` by ServoDaemon::submit; with an empty
  /// path (in-process callers only) used as given.
  control::FeedforwardParameters feedforward{};
  FixedText<48> parameter{};  ///< kGetParameter, kSetParameter: its name, e.g. "control.bandwidth_hz"
  double value = 0.0;       ///< kSetParameter: the new value, in the parameter's unit
  /// kSetParameter: every run-time setting with the change, made by
  /// ServoDaemon::submit from `parameter` and `value`.
  Tuning tuning{};
  /// kMoveTo, kRunProgram, kJog on the cycle's queue: the number of the
  /// program offered for it (CycleMailbox::offers_decided() once decided).
  std::int64_t offer = 0;
};

/// True when `command` reads a file (its route's FileUse; kPathOrValues only
/// with a path).
inline bool reads_file(const Command& command) noexcept {
  switch (route(command.kind).file) {
    case FileUse::kNone: return false;
    case FileUse::kPathOrValues: return !command.path.empty();
    case FileUse::kProgram:
    case FileUse::kPath: return true;
  }
  return false;
}

/// The file `command` names (its route's field), "" for kinds without one.
inline std::string_view file_named(const Command& command) noexcept {
  switch (route(command.kind).file) {
    case FileUse::kNone: return {};
    case FileUse::kProgram: return command.program.view();
    case FileUse::kPath:
    case FileUse::kPathOrValues: return command.path.view();
  }
  return {};
}

}  // namespace clm::servo
