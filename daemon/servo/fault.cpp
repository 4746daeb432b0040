#include "daemon/servo/fault.hpp"

namespace clm::servo {

const char* describe(Fault fault) noexcept {
  switch (fault) {
    case Fault::kNone: return "none";
    case Fault::kEncoderFrameMissing: return "encoder frame missing";
    case Fault::kForceFrameMissing: return "force-sensor frame missing";
    case Fault::kEncoderAliveJump: return "drive alive counter jumped";
    case Fault::kForceAliveJump: return "force-sensor alive counter jumped";
    case Fault::kFrameRejected: return "feedback frame rejected (length or content)";
    case Fault::kBusOff: return "CAN bus-off";
    case Fault::kBusErrorPassive: return "CAN error-passive";
    case Fault::kSendFailed: return "setpoint frame could not be sent";
    case Fault::kMeasurementNotFinite: return "measurement not finite";
    case Fault::kPositionOutOfRange: return "position outside soft limits";
    case Fault::kFollowingError: return "following error above limit";
    case Fault::kForceSaturated: return "force demand saturated too long";
    case Fault::kRepeatedOverruns: return "repeated cycle overruns";
    case Fault::kDriveFault: return "drive reported a fault";
    case Fault::kSetpointOutOfRange: return "setpoint outside CAN signal range";
    case Fault::kCommutationNotFinite: return "commutation produced a non-finite setpoint";
    case Fault::kFeedbackNotFinite: return "position loop produced a non-finite force";
    case Fault::kLoopStalled: return "the loop stalled longer than its limit";
    case Fault::kDriveWatchdog: return "the drive's setpoint watchdog expired";
    case Fault::kEndStop: return "limit switch or end stop active";
    case Fault::kDriveCurrentLimited: return "the drive limited its current too long";
    case Fault::kDriveNotEnabled: return "the drive did not report enabled";
    case Fault::kCommutationNotFound: return "commutation finding found no consistent phase";
    case Fault::kFindingMotion: return "commutation finding moved the axis beyond its bound";
    case Fault::kHomingNotFound: return "homing found no reference within its search distance";
    case Fault::kLatchInvalid: return "the drive's latch is not one the search made";
  }
  return "unknown fault";
}

const char* name(FaultReaction reaction) noexcept {
  switch (reaction) {
    case FaultReaction::kZeroSetpoints: return "zero setpoints at once";
    case FaultReaction::kQuickStop: return "quick stop under position control, then zero setpoints";
  }
  return "unknown";
}

}  // namespace clm::servo
