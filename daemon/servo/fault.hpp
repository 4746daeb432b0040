#pragma once
// Faults of the servo cycle: one numbered enum in bands, latched with the
// cycle it happened in until a clear command (style: moteus fault modes).

#include <cstdint>

namespace clm::servo {

enum class Fault : std::uint16_t {
  kNone = 0,
  // 1xx communication
  kEncoderFrameMissing = 101,   ///< no timely drive feedback for `missing_frame_limit` cycles (late = missing)
  kForceFrameMissing = 102,     ///< no timely force-sensor frame for `missing_frame_limit` cycles
  kEncoderAliveJump = 103,      ///< drive alive counter skipped more than the frames missed
  kForceAliveJump = 104,        ///< force-sensor alive counter skipped more than the frames missed
  kFrameRejected = 105,         ///< as 101/102, and frames of that stream came but were rejected (length, content)
  kBusOff = 106,                ///< the CAN controller went bus-off
  kBusErrorPassive = 107,       ///< the CAN controller went error-passive
  kSendFailed = 108,            ///< a setpoint frame could not be queued
  // 2xx latched faults of the axis
  kMeasurementNotFinite = 201,  ///< decoded position or wrench not finite
  kPositionOutOfRange = 202,    ///< position outside the soft limits
  kFollowingError = 203,        ///< |r − y| above the following-error limit
  kForceSaturated = 204,        ///< force demand at its limit for longer than allowed
  kRepeatedOverruns = 205,      ///< too many consecutive cycle overruns
  kDriveFault = 206,            ///< the drive reported a fault in its status word
  kSetpointOutOfRange = 207,    ///< a setpoint does not fit the CAN signal range
  kCommutationNotFinite = 208,  ///< the commutation law produced a non-finite setpoint
  kFeedbackNotFinite = 209,     ///< the position loop produced a non-finite force demand
};

/// Short fixed text for logs and telemetry; never allocates.
const char* describe(Fault fault) noexcept;

}  // namespace clm::servo
