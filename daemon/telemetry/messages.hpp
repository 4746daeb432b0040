#pragma once
// The messages of clm-servod besides the cycle's record (daemon/servo/
// cycle_record.hpp) and commands (daemon/servo/command.hpp), as fixed-size
// structs the real-time thread can fill without allocating, and the LCM
// channels they go out on (docs/telemetry.md).

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "daemon/servo/fixed_text.hpp"
#include "drivers/drive_signals.hpp"

namespace clm::telemetry {

/// LCM channels of clm-servod.
inline constexpr const char* kStateChannel = "CLM_SERVO_STATE";
inline constexpr const char* kStatusChannel = "CLM_SERVO_STATUS";
inline constexpr const char* kEventChannel = "CLM_SERVO_EVENT";
inline constexpr const char* kCommandChannel = "CLM_SERVO_COMMAND";
inline constexpr const char* kCommandAckChannel = "CLM_SERVO_COMMAND_ACK";

/// servo_event_t.code that a recorder, never the daemon, writes into its own
/// LCM log where it resumes recording after leaving cycles out on purpose
/// (clm commission records the runs only): the step in the cycle counter
/// across it is a pause, not a loss (docs/telemetry.md, "Gaps"). Beside the
/// daemon's event codes (servod::EventCode).
inline constexpr std::int16_t kRecordingResumedEvent = 308;

/// Multicast on the local host only (ttl=0): LCM's default group and port.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

using servo::FixedText;
/// One-line reasons, acks and event texts: up to 511 characters, room for
/// the longest refusal (a 255-character path and the rule it broke), so that
/// no answer is cut.
using ReasonText = FixedText<512>;
/// File paths in commands and status: up to 255 characters.
using PathText = servo::PathText;

/// Daemon health, as servo_status_t, without telemetry_dropped (the
/// publisher fills that in from its own counters).
/// A loaded file as the status names it: canonical path and SHA-256 (hex).
struct LoadedFileText {
  PathText path;
  FixedText<65> sha256;
};

/// Command authority's part of the status (servo_status_t, docs/servod.md).
struct CommandAuthorityStatus {
  std::int64_t control_client = 0;
  double control_lease_remaining_s = 0.0;
  std::int64_t admitted = 0;
  std::int64_t refused_malformed = 0;
  std::int64_t refused_other_axis = 0;
  std::int64_t refused_other_session = 0;
  std::int64_t refused_no_client = 0;
  std::int64_t refused_replayed = 0;
  std::int64_t refused_stale = 0;
  std::int64_t refused_not_in_control = 0;
  std::int64_t refused_by_daemon = 0;
  /// Datagrams the receiver dropped before decoding (TelemetryCounters::datagrams_dropped).
  std::int64_t datagrams_dropped = 0;
  /// Commands refused for a mac not of the operators' key (TelemetryCounters::commands_unauthenticated).
  std::int64_t refused_unauthenticated = 0;
};

/// Bins of the timing histograms in ServoStatusSample (servo_status_t's arrays).
inline constexpr std::size_t kTimingHistogramBins = 31;

struct ServoStatusSample {
  std::int64_t utime = 0;  ///< [µs since the UNIX epoch]; 0 = stamp at publication
  FixedText<33> axis;
  std::int64_t session = 0;
  std::int8_t state = 0;   ///< clm_lcm::servo_status_t::STATE_*
  std::int16_t fault = 0;  ///< daemon/servo/fault.hpp code, 0 = none
  ReasonText fault_reason;
  std::int64_t fault_cycle = -1;  ///< -1 = no fault
  std::int8_t commutation = 0;
  LoadedFileText calibration;
  LoadedFileText pgnn_model;
  LoadedFileText spline_model;
  LoadedFileText feedforward;
  LoadedFileText configuration;  ///< the file the daemon was started from
  LoadedFileText motor;          ///< the motor description it names
  double wakeup_latency_p50_s = 0.0;
  double wakeup_latency_p99_s = 0.0;
  double wakeup_latency_max_s = 0.0;
  double compute_time_p50_s = 0.0;
  double compute_time_p99_s = 0.0;
  double compute_time_max_s = 0.0;
  std::int64_t overruns = 0;
  std::int64_t cycles = 0;
  /// Cumulative histograms, bins as clm_lcm::servo_status_t documents them.
  std::array<std::int64_t, kTimingHistogramBins> wakeup_latency_histogram{};
  std::array<std::int64_t, kTimingHistogramBins> compute_time_histogram{};
  std::int64_t frames_sent = 0;
  std::int64_t frames_received = 0;
  std::int64_t frames_missing = 0;
  std::int64_t frames_late = 0;
  std::int64_t frames_rejected = 0;
  std::int8_t bus_state = -1;  ///< clm_lcm::servo_status_t::BUS_STATE_*
  std::int64_t damping_cycles = 0;
  bool program_running = false;
  double program_time_s = 0.0;
  bool restricted = false;  ///< restricted mode after fault 202
  std::int8_t force_sensor = 0;           ///< clm_lcm::servo_status_t::FORCE_SENSOR_*
  std::int16_t force_sensor_warning = 0;  ///< while lost: the fault an experiment would latch, else 0
  std::int64_t force_sensor_losses = 0;
  std::int16_t drive_signals = 0;  ///< clm_lcm::servo_status_t::DRIVE_* bits
  bool enabling = false;
  std::int64_t current_limited_cycles = 0;
  bool commutation_found = false;
  bool homed = false;
  std::int8_t homing = 0;  ///< clm_lcm::servo_status_t::HOMING_*, the value of servo::HomingPhase
  double found_phase_rad = 0.0;
  double axis_offset_m = 0.0;
  CommandAuthorityStatus commands;
};

/// ServoStatusSample::force_sensor, as clm_lcm::servo_status_t::FORCE_SENSOR_*.
inline constexpr std::int8_t kForceSensorNone = 0;
inline constexpr std::int8_t kForceSensorOk = 1;
inline constexpr std::int8_t kForceSensorLost = 2;

/// ServoStatusSample::drive_signals, as clm_lcm::servo_status_t::DRIVE_*.
inline constexpr std::int16_t kDriveEnabled = 1;
inline constexpr std::int16_t kDriveFault = 2;
inline constexpr std::int16_t kDriveWatchdogExpired = 4;
inline constexpr std::int16_t kDriveCurrentLimited = 8;
inline constexpr std::int16_t kDriveEndStop = 16;
inline constexpr std::int16_t kDriveLatched = 32;
inline constexpr std::int16_t kDriveReferenceSwitch = 64;
constexpr std::int16_t drive_signal_bits(const drivers::DriveSignals& s) noexcept {
  return static_cast<std::int16_t>((s.enabled ? kDriveEnabled : 0) | (s.fault ? kDriveFault : 0) |
                                   (s.watchdog_expired ? kDriveWatchdogExpired : 0) |
                                   (s.current_limited ? kDriveCurrentLimited : 0) | (s.end_stop ? kDriveEndStop : 0) |
                                   (s.latched ? kDriveLatched : 0) | (s.reference_switch ? kDriveReferenceSwitch : 0));
}

/// Something that happened once, as servo_event_t.
struct ServoEventSample {
  std::int64_t utime = 0;  ///< [µs since the UNIX epoch]; 0 = stamp at publication
  std::int64_t cycle = 0;
  std::int16_t code = 0;
  std::int8_t severity = 0;  ///< clm_lcm::servo_event_t::SEVERITY_*
  ReasonText text;
};

/// The cycle's answer to a command, as servo_command_ack_t.
struct ServoCommandAck {
  std::int64_t utime = 0;  ///< 0 = stamp at publication
  std::int64_t sequence = 0;
  std::int64_t client = 0;  ///< the command's client; axis and session are the daemon's
  bool accepted = false;
  ReasonText text;
};

/// Wall-clock time [µs since the UNIX epoch], the LCM convention for utime.
std::int64_t wall_clock_utime() noexcept;
/// `utime`, or wall_clock_utime() when it is 0 ("stamp at publication").
inline std::int64_t stamped(std::int64_t utime) noexcept { return utime != 0 ? utime : wall_clock_utime(); }

}  // namespace clm::telemetry
