#include "daemon/servo/command_result.hpp"

namespace clm::servo {

const char* describe(CommandResult result) noexcept {
  switch (result) {
    case CommandResult::kAccepted: return "accepted";
    case CommandResult::kDeferred: return "accepted, takes effect at the next standstill";
    case CommandResult::kProgramPosted: return "program posted";
    case CommandResult::kJogStarted: return "jog started";
    case CommandResult::kJogging: return "jogging";
    case CommandResult::kLoaded: return "loaded; swapped in at the next standstill";
    case CommandResult::kQueued: return "queued";
    case CommandResult::kLoading: return "loading";
    case CommandResult::kRejectedFault: return "a fault is latched, clear it first";
    case CommandResult::kRejectedDisabled: return "the axis is disabled, enable first";
    case CommandResult::kRejectedNoLaw: return "no calibration or model loaded for that commutation";
    case CommandResult::kRejectedBusy: return "a program is running";
    case CommandResult::kRejectedInvalid: return "argument out of range";
    case CommandResult::kRejectedNoForceSensor:
      return "the force sensor is lost, and an experiment would record no forces";
    case CommandResult::kRejectedRestricted:
      return "restricted mode: only a move_to back inside the soft limits is accepted";
    case CommandResult::kRejectedParameterPending: return "a parameter change is being applied; send the command again";
    case CommandResult::kRejectedOutsideSoftLimits: return "target outside the soft limits";
    case CommandResult::kRejectedMotionLimit: return "a limit exceeds the motion limits";
    case CommandResult::kRejectedStopOutside: return "a stop would come to rest outside the soft limits";
    case CommandResult::kRejectedAtSoftLimit: return "jog: at the soft limit in that direction already";
    case CommandResult::kRejectedOtherJog: return "another jog runs: repeat it unchanged, or stop it first";
    case CommandResult::kRejectedJogStopping:
      return "the jog has timed out and is stopping; send it again once the axis is at rest";
    case CommandResult::kRejectedStartMoved: return "the axis no longer holds the move's start; send it again";
    case CommandResult::kRejectedQueueFull: return "command queue full";
    case CommandResult::kRejectedLoaderBusy: return "busy loading another file";
    case CommandResult::kRejectedLoadWaiting: return "an earlier load is still waiting for standstill";
    case CommandResult::kRejectedFile: return "the file could not be loaded";
    case CommandResult::kRejectedNotHomed:
      return "the axis is not homed: positions are the encoder's reading until `home`; jog and the drive's own law only";
    case CommandResult::kRejectedHoming: return "homing is under way; stop it or wait for it";
    case CommandResult::kRejectedOtherAxis: return "the command names another axis";
    case CommandResult::kRejectedOtherSession: return "the command is for another run of the daemon";
    case CommandResult::kRejectedNoClient: return "client id 0 is not a client";
    case CommandResult::kRejectedReplayed: return "the command's sequence is not above the client's last";
    case CommandResult::kRejectedStale: return "the command is too old, or from the future";
    case CommandResult::kRejectedNotInControl: return "this client does not hold control";
  }
  return "unknown";
}

}  // namespace clm::servo
