#pragma once
// The CAN protocol between the servo daemon, the drive and the force sensor
// (docs/can-protocol.md, drivers/can/clm-servo.dbc).
//
// Classic CAN 2.0A (11-bit identifiers) with CANopen-style COB-IDs, so
// candump, Wireshark and DBC tools read the bus: SYNC 0x080 from the daemon,
// TPDO1 (0x180 + node) from the drive and the force sensor, RPDO1..RPDO3
// (0x200/0x300/0x400 + drive node) with the coil-set setpoints to the drive,
// and TPDO2 (0x280 + drive node), the drive's position latch, sent only in
// the period its latch caught its event.
// Multi-byte fields are little-endian, signed fields two's complement.
//
// Encoding and decoding run in the cycle: they are noexcept, do not allocate
// and report through CodecStatus. An encoder refuses a value outside its
// signal's range (kOutOfRange) or not finite (kNotFinite) and then writes
// nothing; it never clamps. Physical values are rounded to the nearest LSB.
// A decoder checks identifier and DLC and, on failure, writes nothing either.
// The daemon encodes SYNC and setpoints and decodes feedback; the simulated
// drive and sensor nodes do the reverse with the same functions.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "commutation/types.hpp"
#include "drivers/drive_signals.hpp"

namespace clm::can {

/// One classic CAN data frame. Bytes data[dlc..7] are zero in every frame
/// an encoder writes.
struct Frame {
  std::uint32_t id = 0;               ///< 11-bit identifier (COB-ID), 0..0x7FF
  std::uint8_t dlc = 0;               ///< data length [bytes], 0..8
  std::array<std::uint8_t, 8> data{};  ///< payload, data[0] first on the wire
};

/// Result of one encode or decode. Nothing is written unless kOk.
enum class CodecStatus {
  kOk,
  kWrongId,      ///< the frame's identifier is not the one expected (decode)
  kWrongLength,  ///< the frame's DLC is not the protocol's (decode), or the output span is too short (encode_setpoints)
  kOutOfRange,   ///< a value outside its signal's range, a reserved bit set, or an invalid configuration
  kNotFinite,    ///< a NaN or infinite value (encode)
};

/// "ok", "wrong id", "wrong length", "out of range", "not finite".
const char* to_string(CodecStatus status) noexcept;

// ---------------------------------------------------------------------------
// Identifiers and configuration

/// Coil sets the protocol carries: RPDO1 has set 1, RPDO2 sets 2 and 3, RPDO3
/// set 4. Motors with more coil sets (clm::kMaxCoilSets) need another protocol.
inline constexpr int kMaxProtocolCoilSets = 4;
/// Setpoint frames (RPDOs) sent per cycle at most.
inline constexpr std::size_t kMaxSetpointFrames = 3;

inline constexpr std::uint32_t kSyncId = 0x080;       ///< CANopen SYNC
inline constexpr std::uint32_t kTpdo1Base = 0x180;    ///< + node: feedback of drive and force sensor
inline constexpr std::uint32_t kTpdo2Base = 0x280;    ///< + drive node: the drive's position latch (event)
inline constexpr std::uint32_t kRpdo1Base = 0x200;    ///< + drive node: control, alive, coil set 1
inline constexpr std::uint32_t kRpdo2Base = 0x300;    ///< + drive node: coil sets 2 and 3
inline constexpr std::uint32_t kRpdo3Base = 0x400;    ///< + drive node: coil set 4
inline constexpr std::uint32_t kMaxStandardId = 0x7FF;

inline constexpr std::uint8_t kSyncDlc = 1;
inline constexpr std::uint8_t kDriveFeedbackDlc = 7;
inline constexpr std::uint8_t kForceFeedbackDlc = 8;
inline constexpr std::uint8_t kDriveLatchDlc = 5;
inline constexpr std::uint8_t kRpdo1Dlc = 6;
inline constexpr std::uint8_t kRpdo2Dlc = 8;
inline constexpr std::uint8_t kRpdo3Dlc = 4;

/// ProtocolConfig::force_sensor_node_id of an axis without a force sensor
/// (CANopen node 0 is no node: nothing sends a TPDO from it).
inline constexpr std::uint8_t kNoForceSensor = 0;

/// Node IDs and number of coil sets L shared by the daemon and the nodes.
struct ProtocolConfig {
  std::uint8_t drive_node_id = 1;         ///< CANopen node ID of the drive, 1..127
  /// CANopen node ID of the force sensor, 1..127, not the drive's; kNoForceSensor:
  /// the axis has none (service without a sensor, docs/servod.md).
  std::uint8_t force_sensor_node_id = 2;
  int coil_sets = 3;                      ///< L, 1..kMaxProtocolCoilSets
  /// What the RPDOs carry per coil set: magnitude and Δ (clm-servo.dbc) or
  /// i_a and i_b (clm-servo-phase-current.dbc); same identifiers and DLCs.
  clm::DriveProfile drive_profile = clm::DriveProfile::kMagnitudePhase;

  /// Throws std::invalid_argument "can protocol: <field> ..., got <value>" if a
  /// node ID is outside 1..127 (the force sensor's may be kNoForceSensor), both
  /// node IDs are equal, or coil_sets is outside 1..4.
  void validate() const;
  /// The same checks without throwing.
  bool is_valid() const noexcept;
};

/// TPDO1 of the drive, 0x180 + drive_node_id.
constexpr std::uint32_t drive_feedback_id(const ProtocolConfig& config) noexcept {
  return kTpdo1Base + config.drive_node_id;
}
/// TPDO2 of the drive, 0x280 + drive_node_id: its position latch, sent once
/// per latch event, in that period before its TPDO1.
constexpr std::uint32_t drive_latch_id(const ProtocolConfig& config) noexcept {
  return kTpdo2Base + config.drive_node_id;
}
/// The axis has a force sensor (force_sensor_node_id is not kNoForceSensor).
constexpr bool has_force_sensor(const ProtocolConfig& config) noexcept {
  return config.force_sensor_node_id != kNoForceSensor;
}
/// TPDO1 of the force sensor, 0x180 + force_sensor_node_id (meaningless without one).
constexpr std::uint32_t force_feedback_id(const ProtocolConfig& config) noexcept {
  return kTpdo1Base + config.force_sensor_node_id;
}
/// RPDO1, RPDO2, RPDO3 of the drive for frame index 0, 1, 2.
constexpr std::uint32_t setpoint_id(const ProtocolConfig& config, std::size_t frame_index) noexcept {
  constexpr std::array<std::uint32_t, kMaxSetpointFrames> bases{kRpdo1Base, kRpdo2Base, kRpdo3Base};
  return bases[frame_index] + config.drive_node_id;
}
/// RPDOs needed for L coil sets: 1 for L = 1, 2 for L = 2..3, 3 for L = 4 (0 if L is outside 1..4).
constexpr std::size_t setpoint_frame_count(int coil_sets) noexcept {
  if (coil_sets < 1 || coil_sets > kMaxProtocolCoilSets) return 0;
  return coil_sets == 1 ? 1 : (coil_sets <= 3 ? 2 : 3);
}
/// The identifiers the daemon receives: drive feedback, drive latch, and
/// force feedback when the axis has a sensor (count 3; 2 without one).
struct ReceiveIds {
  std::array<std::uint32_t, 3> ids{};
  std::size_t count = 0;
  std::span<const std::uint32_t> view() const noexcept { return {ids.data(), count}; }
};
constexpr ReceiveIds daemon_receive_ids(const ProtocolConfig& config) noexcept {
  if (!has_force_sensor(config)) return {{drive_feedback_id(config), drive_latch_id(config), 0}, 2};
  return {{drive_feedback_id(config), drive_latch_id(config), force_feedback_id(config)}, 3};
}

// ---------------------------------------------------------------------------
// Signals

/// Status word bits of the drive feedback; bits 7..15 are reserved and 0.
inline constexpr std::uint16_t kStatusEnabled = 1u << 0;
inline constexpr std::uint16_t kStatusFault = 1u << 1;
inline constexpr std::uint16_t kStatusWatchdogExpired = 1u << 2;
inline constexpr std::uint16_t kStatusCurrentLimited = 1u << 3;
inline constexpr std::uint16_t kStatusEndStop = 1u << 4;
/// The latch caught its event since it was armed; clears when disarmed.
inline constexpr std::uint16_t kStatusLatched = 1u << 5;
/// The reference switch is active now.
inline constexpr std::uint16_t kStatusReferenceSwitch = 1u << 6;
inline constexpr std::uint16_t kStatusReservedMask = 0xFF80;

/// Control byte bits of RPDO1; bits 4..7 are reserved and 0.
inline constexpr std::uint8_t kControlEnable = 1u << 0;
inline constexpr std::uint8_t kControlClearFault = 1u << 1;
/// Arm the drive's position latch: while set, the drive latches its position
/// reading once, at the next latch event.
inline constexpr std::uint8_t kControlArmLatch = 1u << 2;
/// The latch event is the reference switch becoming active, instead of the
/// encoder's next index mark.
inline constexpr std::uint8_t kControlLatchOnSwitch = 1u << 3;
inline constexpr std::uint8_t kControlReservedMask = 0xF0;

/// SYNC counter range (CANopen, CiA 301: 1 up to the overflow value, then 1 again).
inline constexpr std::uint8_t kSyncCounterFirst = 1;
inline constexpr std::uint8_t kSyncCounterLast = 240;

/// Resolution (one LSB) of each scaled signal, in the unit its name gives.
inline constexpr double kPositionLsb_m = 1e-9;
inline constexpr double kForceYLsb_N = 1e-3;
inline constexpr double kForceXLsb_N = 1e-2;
inline constexpr double kTorqueZLsb_Nm = 1e-3;
inline constexpr double kMagnitudeLsb_N = 0.025;
inline constexpr double kDeltaLsb_rad = 1e-4;
inline constexpr double kCurrentLsb_A = 1e-3;  ///< phase_current profile: int16 ±32.767 A

/// The counter after `counter` in a SYNC: 1, 2, ..., 240, 1, ...
constexpr std::uint8_t next_sync_counter(std::uint8_t counter) noexcept {
  return counter >= kSyncCounterLast ? kSyncCounterFirst : static_cast<std::uint8_t>(counter + 1);
}

/// TPDO1 of the drive.
struct DriveFeedback {
  double position_m = 0.0;          ///< measured position [m], int32 in nm on the wire (±2.147 m)
  std::uint16_t status_word = 0;    ///< kStatus* bits
  std::uint8_t alive_counter = 0;   ///< +1 per frame, wraps 255 → 0
};

/// The signals of a status word (kStatus* bits).
constexpr drivers::DriveSignals drive_signals(std::uint16_t status_word) noexcept {
  drivers::DriveSignals signals;
  signals.enabled = (status_word & kStatusEnabled) != 0;
  signals.fault = (status_word & kStatusFault) != 0;
  signals.watchdog_expired = (status_word & kStatusWatchdogExpired) != 0;
  signals.current_limited = (status_word & kStatusCurrentLimited) != 0;
  signals.end_stop = (status_word & kStatusEndStop) != 0;
  signals.latched = (status_word & kStatusLatched) != 0;
  signals.reference_switch = (status_word & kStatusReferenceSwitch) != 0;
  return signals;
}

/// TPDO2 of the drive: the position its latch caught. Sent once per latch,
/// in the period the latch happened, before that period's TPDO1.
struct DriveLatch {
  double position_m = 0.0;        ///< latched position [m], int32 in nm on the wire as DriveFeedback's (±2.147 m)
  std::uint8_t latch_count = 0;   ///< +1 per latch, wraps 255 → 0
};

/// TPDO1 of the force sensor.
struct ForceFeedback {
  clm::Wrench wrench = clm::Wrench::Zero();  ///< [F_y N, F_x N, T_z N·m]; ±8388.608 N, ±327.68 N, ±32.768 N·m
  std::uint8_t alive_counter = 0;            ///< +1 per frame, wraps 255 → 0
};

/// RPDO1..RPDO3 of the drive together: one cycle's setpoints.
struct SetpointCommand {
  bool enable = false;             ///< control bit 0: power stage enabled
  bool clear_fault = false;        ///< control bit 1: request to clear a latched fault
  bool arm_latch = false;          ///< control bit 2: position latch armed (kControlArmLatch)
  bool latch_on_switch = false;    ///< control bit 3: latch on the reference switch, not the index (kControlLatchOnSwitch)
  std::uint8_t alive_counter = 0;  ///< +1 per cycle, wraps 255 → 0
  int coil_sets = 0;               ///< L; must equal ProtocolConfig::coil_sets
  /// Profile magnitude_phase: setpoints[l] for coil set l+1, l < L:
  /// magnitude ±819.2 N in 0.025 N, Δ ±3.2768 rad in 1e-4 rad.
  std::array<clm::DriveSetpoint, clm::kMaxCoilSets> setpoints{};
  /// Profile phase_current: currents[l] for coil set l+1, l < L: i_a, i_b
  /// each −32.768 .. 32.767 A in 1 mA.
  std::array<clm::PhaseCurrentSetpoint, clm::kMaxCoilSets> currents{};
};

// ---------------------------------------------------------------------------
// Codec. All functions: noexcept, no allocation; nothing written unless kOk.

/// SYNC, DLC 1: the counter, 1..240 (0 and 241..255 are kOutOfRange).
CodecStatus encode_sync(std::uint8_t sync_counter, Frame& out) noexcept;
CodecStatus decode_sync(const Frame& frame, std::uint8_t& sync_counter) noexcept;

/// Drive TPDO1, DLC 7. kOutOfRange for a position outside int32 nm after
/// rounding or a reserved status bit set (both directions).
CodecStatus encode_drive_feedback(const ProtocolConfig& config, const DriveFeedback& feedback, Frame& out) noexcept;
CodecStatus decode_drive_feedback(const ProtocolConfig& config, const Frame& frame, DriveFeedback& feedback) noexcept;

/// Drive TPDO2 (position latch), DLC 5: position as in the drive feedback,
/// latch count in byte 4. kOutOfRange for a position outside int32 nm after
/// rounding.
CodecStatus encode_drive_latch(const ProtocolConfig& config, const DriveLatch& latch, Frame& out) noexcept;
CodecStatus decode_drive_latch(const ProtocolConfig& config, const Frame& frame, DriveLatch& latch) noexcept;

/// Force-sensor TPDO1, DLC 8. kOutOfRange when the config has no force sensor.
CodecStatus encode_force_feedback(const ProtocolConfig& config, const ForceFeedback& feedback, Frame& out) noexcept;
CodecStatus decode_force_feedback(const ProtocolConfig& config, const Frame& frame, ForceFeedback& feedback) noexcept;

/// Writes the setpoint_frame_count(L) RPDOs of `command` to out[0..] and
/// returns how many: command.setpoints with profile magnitude_phase,
/// command.currents with phase_current (config.drive_profile); the other
/// array is neither sent nor checked. It
/// returns how many. Returns 0 and writes nothing when `status` is not kOk:
/// kOutOfRange if command.coil_sets != config.coil_sets, the config is invalid
/// or a value is out of range; kNotFinite for NaN/inf; kWrongLength if `out`
/// is too short. For L = 2 the coil-set-3 fields of RPDO2 are sent as zero.
std::size_t encode_setpoints(const ProtocolConfig& config, const SetpointCommand& command, std::span<Frame> out,
                             CodecStatus& status) noexcept;

/// Decodes one RPDO of the drive into `accumulate` (RPDO1: control, alive
/// counter, set 1; RPDO2: sets 2, 3; RPDO3: set 4; into accumulate.setpoints
/// or accumulate.currents by config.drive_profile) and sets
/// accumulate.coil_sets = L. kWrongId for an RPDO that L does not use;
/// kOutOfRange for a reserved control bit, or non-zero coil-set-3 fields when
/// L = 2 (the two ends disagree on L).
CodecStatus decode_setpoint_frame(const ProtocolConfig& config, const Frame& frame,
                                  SetpointCommand& accumulate) noexcept;

// ---------------------------------------------------------------------------
// Bus load (offline, at start-up)

/// Worst-case length [bits] of a classic standard data frame with `dlc` data
/// bytes, interframe space included: 47 + 8·dlc fixed bits plus at most one
/// stuff bit per 4 of the 34 + 8·dlc stuffable ones, ⌊(33 + 8·dlc)/4⌋
/// (Davis et al., Real-Time Systems 35, 2007). 65 bits for DLC 1, 135 for DLC 8.
constexpr std::uint32_t worst_case_frame_bits(std::uint8_t dlc) noexcept {
  return 47u + 8u * dlc + (33u + 8u * dlc) / 4u;
}

/// Worst-case bits of one cycle's schedule: SYNC, drive feedback, force
/// feedback (when the axis has a sensor) and the RPDOs for L. Per cycle: the
/// drive latch (TPDO2) is an event frame, at most one per arming (one per
/// homing), so it is not counted; it adds worst_case_frame_bits(kDriveLatchDlc)
/// = 105 bits to the one cycle it is sent in. Throws std::invalid_argument if the config is invalid.
std::uint32_t cycle_bits(const ProtocolConfig& config);

/// Worst-case bus load of the cycle schedule as a fraction (0.575 = 57.5 %):
/// cycle_bits · cycle_rate_hz / bitrate_bps. Throws std::invalid_argument if
/// the config is invalid or a rate is not positive and finite.
double bus_load(const ProtocolConfig& config, double bitrate_bps, double cycle_rate_hz);

/// Throws std::invalid_argument with the computed load in percent if
/// bus_load(...) exceeds `limit` (a fraction, default 70 %); returns the load otherwise.
double check_bus_load(const ProtocolConfig& config, double bitrate_bps, double cycle_rate_hz, double limit = 0.70);

/// candump-like text of a frame for logs and tests, e.g.
/// "0x181 [7] 15 CD 5B 07 01 00 2A". Allocates: not for the cycle.
std::string describe(const Frame& frame);

}  // namespace clm::can
