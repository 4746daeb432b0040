#pragma once
// Faults of the servo cycle: one numbered enum in bands, latched with the
// cycle it happened in until a clear command (style: moteus fault modes).

#include <array>
#include <cstddef>
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
  kLoopStalled = 210,           ///< the loop did not run for longer than `stall_limit_s` (a stall, SIGSTOP)
  // The drive's own signals (drivers/drive_signals.hpp; docs/servod.md, "The drive's own signals")
  kDriveWatchdog = 211,         ///< the drive's setpoint watchdog expired
  kEndStop = 212,               ///< a limit switch or end stop is active
  kDriveCurrentLimited = 213,   ///< the drive limited its current longer than `current_limited_limit_s`
  kDriveNotEnabled = 214,       ///< the drive did not report Enabled within `enable_timeout_s`, or stopped reporting it
  // Homing (docs/servod.md, "Homing").
  kCommutationNotFound = 215,   ///< commutation finding saw too little motion, or motion no phase explains
  kFindingMotion = 216,         ///< the axis moved beyond homing.commutation_finding.max_motion_m
  kHomingNotFound = 217,        ///< no reference event within homing.search_distance_m
  kLatchInvalid = 218,          ///< a latch frame without the drive's Latched, Latched without a frame, or a latched position the search did not pass
};

/// Short fixed text for logs and telemetry; never allocates.
const char* describe(Fault fault) noexcept;

/// What the cycle does when a fault latches while it drives the axis (CiA 402
/// fault reaction codes in spirit; docs/servod.md, "Fault reactions").
enum class FaultReaction : std::uint8_t {
  /// Setpoints to zero and enable cleared in the cycle the fault is found:
  /// the position feedback or the path to the drive cannot be trusted.
  kZeroSetpoints,
  /// The position feedback is still trustworthy: the reference stops from its
  /// present state at the quick-stop limits with the loop closed, then the
  /// setpoints go to zero. The fault is latched from the start all the same.
  kQuickStop,
};
const char* name(FaultReaction reaction) noexcept;

struct FaultReactionEntry {
  Fault fault;
  FaultReaction reaction;
};

/// Every fault and its reaction, in the order of the enum (docs/servod.md prints it).
inline constexpr std::array<FaultReactionEntry, 26> kFaultReactions{{
    {Fault::kEncoderFrameMissing, FaultReaction::kZeroSetpoints},
    {Fault::kForceFrameMissing, FaultReaction::kQuickStop},
    {Fault::kEncoderAliveJump, FaultReaction::kZeroSetpoints},
    {Fault::kForceAliveJump, FaultReaction::kQuickStop},
    {Fault::kFrameRejected, FaultReaction::kZeroSetpoints},
    {Fault::kBusOff, FaultReaction::kZeroSetpoints},
    {Fault::kBusErrorPassive, FaultReaction::kZeroSetpoints},
    {Fault::kSendFailed, FaultReaction::kZeroSetpoints},
    {Fault::kMeasurementNotFinite, FaultReaction::kZeroSetpoints},
    {Fault::kPositionOutOfRange, FaultReaction::kQuickStop},
    {Fault::kFollowingError, FaultReaction::kQuickStop},
    {Fault::kForceSaturated, FaultReaction::kQuickStop},
    {Fault::kRepeatedOverruns, FaultReaction::kQuickStop},
    {Fault::kDriveFault, FaultReaction::kZeroSetpoints},
    {Fault::kSetpointOutOfRange, FaultReaction::kZeroSetpoints},
    {Fault::kCommutationNotFinite, FaultReaction::kZeroSetpoints},
    {Fault::kFeedbackNotFinite, FaultReaction::kZeroSetpoints},
    // The feedback is fresh again when the loop resumes; the drive's own
    // watchdog zeroed its setpoints meanwhile, or the axis ran on the last ones.
    {Fault::kLoopStalled, FaultReaction::kQuickStop},
    // The drive stopped its current itself, or may not apply what it is sent.
    {Fault::kDriveWatchdog, FaultReaction::kZeroSetpoints},
    // The axis is where it must not be but its feedback is sound: braked with
    // the loop closed, as long as the drive still applies current.
    {Fault::kEndStop, FaultReaction::kQuickStop},
    {Fault::kDriveCurrentLimited, FaultReaction::kQuickStop},
    {Fault::kDriveNotEnabled, FaultReaction::kZeroSetpoints},
    // The loop is open while the commutation is found: nothing to brake with.
    {Fault::kCommutationNotFound, FaultReaction::kZeroSetpoints},
    {Fault::kFindingMotion, FaultReaction::kZeroSetpoints},
    // The search runs with the loop closed on a found commutation.
    {Fault::kHomingNotFound, FaultReaction::kQuickStop},
    {Fault::kLatchInvalid, FaultReaction::kQuickStop},
}};

/// The reaction to `fault` from kFaultReactions; kZeroSetpoints for any value
/// not in it.
constexpr FaultReaction reaction(Fault fault) noexcept {
  for (const auto& entry : kFaultReactions) {
    if (entry.fault == fault) return entry.reaction;
  }
  return FaultReaction::kZeroSetpoints;
}

}  // namespace clm::servo
