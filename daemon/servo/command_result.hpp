#pragma once
// The one result of a command inside clm-servod: what the command
// authority, the cycle, the move decision (move_decision.hpp) and the daemon
// answer, as one enum with one describe(). The words of every answer are written here once; the ack on
// CLM_SERVO_COMMAND_ACK carries them (telemetry::to_message), and clm ctl
// prints them.

#include <cstdint>

namespace clm::servo {

enum class CommandResult : std::uint8_t {
  // Accepted.
  kAccepted,
  kDeferred,        ///< takes effect at the next standstill
  kProgramPosted,   ///< the cycle has taken the move, program or jog and runs it
  kJogStarted,      ///< as kProgramPosted, for a jog
  kJogging,         ///< a repeat renewed the running jog
  kLoaded,          ///< a law was built from its file and waits for standstill
  // Not an answer yet: the cycle (kQueued) or the loader (kLoading) answers later.
  kQueued,
  kLoading,
  // Refused.
  kRejectedFault,           ///< a fault is latched
  kRejectedDisabled,        ///< the axis is disabled
  kRejectedNoLaw,           ///< no calibration or model loaded for that mode
  kRejectedBusy,            ///< a program, jog or stop is under way, or a program waits to start
  kRejectedInvalid,         ///< an argument out of range (the detail says which)
  kRejectedNoForceSensor,   ///< an experiment, and the axis has lost its force sensor
  kRejectedRestricted,      ///< restricted mode allows only a move_to back inside
  kRejectedParameterPending,  ///< a run-time parameter change is on its way to the cycle
  kRejectedOutsideSoftLimits,  ///< a target outside the soft limits
  kRejectedMotionLimit,     ///< a velocity, acceleration or jerk above motion: (the detail names value and limit)
  kRejectedStopOutside,     ///< a stop from some cycle of the move would rest outside the soft limits (detail)
  kRejectedAtSoftLimit,     ///< a jog towards the soft limit it is at already
  kRejectedOtherJog,        ///< a jog with other parameters runs
  kRejectedJogStopping,     ///< the jog timed out and is stopping
  kRejectedStartMoved,      ///< the cycle's hold position is no longer the move's start
  kRejectedQueueFull,       ///< the cycle's command queue is full
  kRejectedLoaderBusy,      ///< another file is being loaded (the detail names it)
  kRejectedLoadWaiting,     ///< a law loaded earlier still waits for standstill
  kRejectedFile,            ///< the file named could not be loaded (the detail: rule or place, and path)
  kRejectedNotHomed,        ///< a move to a position, or a position-dependent law, before homing
  kRejectedHoming,          ///< homing is under way (commutation finding included)
  // Refused by the command authority (daemon/servod/command_gate.hpp).
  kRejectedOtherAxis,       ///< the command names another axis
  kRejectedOtherSession,    ///< the command is for another run of the daemon
  kRejectedNoClient,        ///< client id 0
  kRejectedReplayed,        ///< sequence not above the client's last admitted one
  kRejectedStale,           ///< sent longer ago than commands.max_age_s, or in the future
  kRejectedNotInControl,    ///< another client holds control, or nobody does
};

/// The answer's words, e.g. "a fault is latched, clear it first"; a refusal's
/// without the "rejected: " that reply_text() puts before it.
const char* describe(CommandResult result) noexcept;
/// False for the refusals.
constexpr bool is_accepted(CommandResult result) noexcept { return result < CommandResult::kRejectedFault; }
/// True for kQueued and kLoading: an answer follows.
constexpr bool answered_later(CommandResult result) noexcept {
  return result == CommandResult::kQueued || result == CommandResult::kLoading;
}

}  // namespace clm::servo
