#include "drivers/can/can_protocol.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace clm::can {
namespace {

// Raw integer per physical unit of each scaled signal (the inverse LSB). Exact
// integers, so that encoding multiplies and decoding divides by an exact
// number: a decoded value is the double nearest to raw·LSB.
constexpr double kPositionRawPerMetre = 1e9;
constexpr double kForceYRawPerNewton = 1e3;
constexpr double kForceXRawPerNewton = 1e2;
constexpr double kTorqueZRawPerNewtonMetre = 1e3;
constexpr double kMagnitudeRawPerNewton = 40.0;  // 1 / 0.025 N
constexpr double kDeltaRawPerRadian = 1e4;
constexpr double kCurrentRawPerAmpere = 1e3;

constexpr std::int64_t kInt16Min = -32768;
constexpr std::int64_t kInt16Max = 32767;
constexpr std::int64_t kInt24Min = -8388608;
constexpr std::int64_t kInt24Max = 8388607;
constexpr std::int64_t kInt32Min = -2147483648LL;
constexpr std::int64_t kInt32Max = 2147483647LL;

/// Rounds value·raw_per_unit to the nearest integer and checks it fits.
CodecStatus to_raw(double value, double raw_per_unit, std::int64_t min_raw, std::int64_t max_raw,
                   std::int64_t& raw) noexcept {
  if (!std::isfinite(value)) return CodecStatus::kNotFinite;
  const double scaled = std::round(value * raw_per_unit);  // ±inf for huge values: refused below
  if (!(scaled >= static_cast<double>(min_raw) && scaled <= static_cast<double>(max_raw))) {
    return CodecStatus::kOutOfRange;
  }
  raw = static_cast<std::int64_t>(scaled);
  return CodecStatus::kOk;
}

/// Writes the low `bytes` bytes of raw (two's complement) little-endian.
void put_le(std::array<std::uint8_t, 8>& data, std::size_t offset, std::size_t bytes, std::int64_t raw) noexcept {
  const auto bits = static_cast<std::uint64_t>(raw);
  for (std::size_t i = 0; i < bytes; ++i) data[offset + i] = static_cast<std::uint8_t>(bits >> (8 * i));
}

std::uint64_t get_unsigned_le(const std::array<std::uint8_t, 8>& data, std::size_t offset, std::size_t bytes) noexcept {
  std::uint64_t bits = 0;
  for (std::size_t i = 0; i < bytes; ++i) bits |= static_cast<std::uint64_t>(data[offset + i]) << (8 * i);
  return bits;
}

/// Reads a `bytes`-byte two's complement little-endian integer.
std::int64_t get_signed_le(const std::array<std::uint8_t, 8>& data, std::size_t offset, std::size_t bytes) noexcept {
  const std::uint64_t bits = get_unsigned_le(data, offset, bytes);
  const std::uint64_t sign = std::uint64_t{1} << (8 * bytes - 1);
  return static_cast<std::int64_t>(bits ^ sign) - static_cast<std::int64_t>(sign);
}

bool node_id_valid(std::uint8_t node_id) noexcept { return node_id >= 1 && node_id <= 127; }

/// The two int16 fields of one coil set: magnitude and Δ (profile
/// magnitude_phase) or i_a and i_b (phase_current).
struct RawSetpoint {
  std::int64_t magnitude = 0;  ///< or i_a
  std::int64_t delta = 0;      ///< or i_b
};

CodecStatus setpoint_to_raw(const clm::DriveSetpoint& setpoint, RawSetpoint& raw) noexcept {
  CodecStatus status = to_raw(setpoint.magnitude_N, kMagnitudeRawPerNewton, kInt16Min, kInt16Max, raw.magnitude);
  if (status != CodecStatus::kOk) return status;
  return to_raw(setpoint.delta_rad, kDeltaRawPerRadian, kInt16Min, kInt16Max, raw.delta);
}

CodecStatus currents_to_raw(const clm::PhaseCurrentSetpoint& currents, RawSetpoint& raw) noexcept {
  CodecStatus status = to_raw(currents.ia_A, kCurrentRawPerAmpere, kInt16Min, kInt16Max, raw.magnitude);
  if (status != CodecStatus::kOk) return status;
  return to_raw(currents.ib_A, kCurrentRawPerAmpere, kInt16Min, kInt16Max, raw.delta);
}

void put_setpoint(std::array<std::uint8_t, 8>& data, std::size_t offset, const RawSetpoint& raw) noexcept {
  put_le(data, offset, 2, raw.magnitude);
  put_le(data, offset + 2, 2, raw.delta);
}

clm::DriveSetpoint get_setpoint(const std::array<std::uint8_t, 8>& data, std::size_t offset) noexcept {
  clm::DriveSetpoint setpoint;
  setpoint.magnitude_N = static_cast<double>(get_signed_le(data, offset, 2)) / kMagnitudeRawPerNewton;
  setpoint.delta_rad = static_cast<double>(get_signed_le(data, offset + 2, 2)) / kDeltaRawPerRadian;
  return setpoint;
}

clm::PhaseCurrentSetpoint get_currents(const std::array<std::uint8_t, 8>& data, std::size_t offset) noexcept {
  clm::PhaseCurrentSetpoint currents;
  currents.ia_A = static_cast<double>(get_signed_le(data, offset, 2)) / kCurrentRawPerAmpere;
  currents.ib_A = static_cast<double>(get_signed_le(data, offset + 2, 2)) / kCurrentRawPerAmpere;
  return currents;
}

/// Coil set `l` of an RPDO into the array of the configured profile.
void store_coil_set(const ProtocolConfig& config, const std::array<std::uint8_t, 8>& data, std::size_t offset,
                    std::size_t l, SetpointCommand& accumulate) noexcept {
  if (config.drive_profile == clm::DriveProfile::kPhaseCurrent) {
    accumulate.currents[l] = get_currents(data, offset);
  } else {
    accumulate.setpoints[l] = get_setpoint(data, offset);
  }
}

bool profile_valid(clm::DriveProfile profile) noexcept {
  return profile == clm::DriveProfile::kMagnitudePhase || profile == clm::DriveProfile::kPhaseCurrent;
}

CodecStatus check_frame(const Frame& frame, std::uint32_t id, std::uint8_t dlc) noexcept {
  if (frame.id != id) return CodecStatus::kWrongId;
  if (frame.dlc != dlc) return CodecStatus::kWrongLength;
  return CodecStatus::kOk;
}

std::string format_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", value);
  return text;
}

void require_positive_finite(const char* name, double value) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("can bus load: ") + name + " must be positive and finite, got " +
                                format_number(value));
  }
}

}  // namespace

const char* to_string(CodecStatus status) noexcept {
  switch (status) {
    case CodecStatus::kOk: return "ok";
    case CodecStatus::kWrongId: return "wrong id";
    case CodecStatus::kWrongLength: return "wrong length";
    case CodecStatus::kOutOfRange: return "out of range";
    case CodecStatus::kNotFinite: return "not finite";
  }
  return "unknown";
}

bool ProtocolConfig::is_valid() const noexcept {
  return node_id_valid(drive_node_id) &&
         (force_sensor_node_id == kNoForceSensor || node_id_valid(force_sensor_node_id)) &&
         drive_node_id != force_sensor_node_id && coil_sets >= 1 && coil_sets <= kMaxProtocolCoilSets &&
         profile_valid(drive_profile);
}

void ProtocolConfig::validate() const {
  if (!node_id_valid(drive_node_id)) {
    throw std::invalid_argument("can protocol: drive_node_id must be a CANopen node ID 1..127, got " +
                                std::to_string(drive_node_id));
  }
  if (force_sensor_node_id != kNoForceSensor && !node_id_valid(force_sensor_node_id)) {
    throw std::invalid_argument("can protocol: force_sensor_node_id must be a CANopen node ID 1..127 (or absent: "
                                "no force sensor), got " +
                                std::to_string(force_sensor_node_id));
  }
  if (drive_node_id == force_sensor_node_id) {
    throw std::invalid_argument("can protocol: force_sensor_node_id must differ from drive_node_id (both TPDO1 at 0x180 + node), got " +
                                std::to_string(force_sensor_node_id) + " for both");
  }
  if (coil_sets < 1 || coil_sets > kMaxProtocolCoilSets) {
    throw std::invalid_argument(
        "can protocol: coil_sets must be 1..4 (the protocol carries at most 4 coil sets: set 1 in RPDO1, "
        "sets 2-3 in RPDO2, set 4 in RPDO3), got " +
        std::to_string(coil_sets));
  }
  if (!profile_valid(drive_profile)) {
    throw std::invalid_argument("can protocol: drive_profile must be magnitude_phase or phase_current, got " +
                                std::to_string(static_cast<int>(drive_profile)));
  }
}

// --- SYNC -------------------------------------------------------------------

CodecStatus encode_sync(std::uint8_t sync_counter, Frame& out) noexcept {
  if (sync_counter < kSyncCounterFirst || sync_counter > kSyncCounterLast) return CodecStatus::kOutOfRange;
  Frame frame;
  frame.id = kSyncId;
  frame.dlc = kSyncDlc;
  frame.data[0] = sync_counter;
  out = frame;
  return CodecStatus::kOk;
}

CodecStatus decode_sync(const Frame& frame, std::uint8_t& sync_counter) noexcept {
  const CodecStatus status = check_frame(frame, kSyncId, kSyncDlc);
  if (status != CodecStatus::kOk) return status;
  const std::uint8_t counter = frame.data[0];
  if (counter < kSyncCounterFirst || counter > kSyncCounterLast) return CodecStatus::kOutOfRange;
  sync_counter = counter;
  return CodecStatus::kOk;
}

// --- Drive feedback (TPDO1 of the drive) -------------------------------------
// bytes 0..3 position int32 [nm], 4..5 status word uint16, 6 alive counter.

CodecStatus encode_drive_feedback(const ProtocolConfig& config, const DriveFeedback& feedback, Frame& out) noexcept {
  if (!config.is_valid()) return CodecStatus::kOutOfRange;
  std::int64_t position = 0;
  const CodecStatus status = to_raw(feedback.position_m, kPositionRawPerMetre, kInt32Min, kInt32Max, position);
  if (status != CodecStatus::kOk) return status;
  if ((feedback.status_word & kStatusReservedMask) != 0) return CodecStatus::kOutOfRange;
  Frame frame;
  frame.id = drive_feedback_id(config);
  frame.dlc = kDriveFeedbackDlc;
  put_le(frame.data, 0, 4, position);
  put_le(frame.data, 4, 2, feedback.status_word);
  frame.data[6] = feedback.alive_counter;
  out = frame;
  return CodecStatus::kOk;
}

CodecStatus decode_drive_feedback(const ProtocolConfig& config, const Frame& frame, DriveFeedback& feedback) noexcept {
  if (!config.is_valid()) return CodecStatus::kOutOfRange;
  const CodecStatus status = check_frame(frame, drive_feedback_id(config), kDriveFeedbackDlc);
  if (status != CodecStatus::kOk) return status;
  const auto status_word = static_cast<std::uint16_t>(get_unsigned_le(frame.data, 4, 2));
  if ((status_word & kStatusReservedMask) != 0) return CodecStatus::kOutOfRange;
  feedback.position_m = static_cast<double>(get_signed_le(frame.data, 0, 4)) / kPositionRawPerMetre;
  feedback.status_word = status_word;
  feedback.alive_counter = frame.data[6];
  return CodecStatus::kOk;
}

// --- Drive latch (TPDO2 of the drive) ----------------------------------------
// bytes 0..3 latched position int32 [nm] (as in the drive feedback), 4 latch count.

CodecStatus encode_drive_latch(const ProtocolConfig& config, const DriveLatch& latch, Frame& out) noexcept {
  if (!config.is_valid()) return CodecStatus::kOutOfRange;
  std::int64_t position = 0;
  const CodecStatus status = to_raw(latch.position_m, kPositionRawPerMetre, kInt32Min, kInt32Max, position);
  if (status != CodecStatus::kOk) return status;
  Frame frame;
  frame.id = drive_latch_id(config);
  frame.dlc = kDriveLatchDlc;
  put_le(frame.data, 0, 4, position);
  frame.data[4] = latch.latch_count;
  out = frame;
  return CodecStatus::kOk;
}

CodecStatus decode_drive_latch(const ProtocolConfig& config, const Frame& frame, DriveLatch& latch) noexcept {
  if (!config.is_valid()) return CodecStatus::kOutOfRange;
  const CodecStatus status = check_frame(frame, drive_latch_id(config), kDriveLatchDlc);
  if (status != CodecStatus::kOk) return status;
  latch.position_m = static_cast<double>(get_signed_le(frame.data, 0, 4)) / kPositionRawPerMetre;
  latch.latch_count = frame.data[4];
  return CodecStatus::kOk;
}

// --- Force feedback (TPDO1 of the force sensor) ------------------------------
// bytes 0..2 F_y int24 [mN], 3..4 F_x int16 [10 mN], 5..6 T_z int16 [mN·m], 7 alive counter.

CodecStatus encode_force_feedback(const ProtocolConfig& config, const ForceFeedback& feedback, Frame& out) noexcept {
  if (!config.is_valid() || !has_force_sensor(config)) return CodecStatus::kOutOfRange;
  std::int64_t force_y = 0;
  std::int64_t force_x = 0;
  std::int64_t torque_z = 0;
  CodecStatus status = to_raw(feedback.wrench[0], kForceYRawPerNewton, kInt24Min, kInt24Max, force_y);
  if (status != CodecStatus::kOk) return status;
  status = to_raw(feedback.wrench[1], kForceXRawPerNewton, kInt16Min, kInt16Max, force_x);
  if (status != CodecStatus::kOk) return status;
  status = to_raw(feedback.wrench[2], kTorqueZRawPerNewtonMetre, kInt16Min, kInt16Max, torque_z);
  if (status != CodecStatus::kOk) return status;
  Frame frame;
  frame.id = force_feedback_id(config);
  frame.dlc = kForceFeedbackDlc;
  put_le(frame.data, 0, 3, force_y);
  put_le(frame.data, 3, 2, force_x);
  put_le(frame.data, 5, 2, torque_z);
  frame.data[7] = feedback.alive_counter;
  out = frame;
  return CodecStatus::kOk;
}

CodecStatus decode_force_feedback(const ProtocolConfig& config, const Frame& frame, ForceFeedback& feedback) noexcept {
  if (!config.is_valid() || !has_force_sensor(config)) return CodecStatus::kOutOfRange;
  const CodecStatus status = check_frame(frame, force_feedback_id(config), kForceFeedbackDlc);
  if (status != CodecStatus::kOk) return status;
  feedback.wrench[0] = static_cast<double>(get_signed_le(frame.data, 0, 3)) / kForceYRawPerNewton;
  feedback.wrench[1] = static_cast<double>(get_signed_le(frame.data, 3, 2)) / kForceXRawPerNewton;
  feedback.wrench[2] = static_cast<double>(get_signed_le(frame.data, 5, 2)) / kTorqueZRawPerNewtonMetre;
  feedback.alive_counter = frame.data[7];
  return CodecStatus::kOk;
}

// --- Setpoints (RPDO1..RPDO3 of the drive) -----------------------------------
// RPDO1: 0 control byte (bits 0..3: enable, clear fault, arm latch, latch on
// switch), 1 alive counter, 2..3 magnitude 1, 4..5 Δ 1.
// RPDO2: 0..1 magnitude 2, 2..3 Δ 2, 4..5 magnitude 3, 6..7 Δ 3.
// RPDO3: 0..1 magnitude 4, 2..3 Δ 4.
// Profile phase_current: i_a in place of the magnitude, i_b in place of Δ.

std::size_t encode_setpoints(const ProtocolConfig& config, const SetpointCommand& command, std::span<Frame> out,
                             CodecStatus& status) noexcept {
  if (!config.is_valid() || command.coil_sets != config.coil_sets) {
    status = CodecStatus::kOutOfRange;
    return 0;
  }
  const std::size_t frame_count = setpoint_frame_count(config.coil_sets);
  if (out.size() < frame_count) {
    status = CodecStatus::kWrongLength;
    return 0;
  }
  // Convert every value first, so that nothing is written if one is refused.
  std::array<RawSetpoint, kMaxProtocolCoilSets> raw{};
  for (int l = 0; l < config.coil_sets; ++l) {
    const auto s = static_cast<std::size_t>(l);
    const CodecStatus converted = config.drive_profile == clm::DriveProfile::kPhaseCurrent
                                      ? currents_to_raw(command.currents[s], raw[s])
                                      : setpoint_to_raw(command.setpoints[s], raw[s]);
    if (converted != CodecStatus::kOk) {
      status = converted;
      return 0;
    }
  }

  Frame rpdo1;
  rpdo1.id = setpoint_id(config, 0);
  rpdo1.dlc = kRpdo1Dlc;
  rpdo1.data[0] = static_cast<std::uint8_t>(
      (command.enable ? kControlEnable : 0) | (command.clear_fault ? kControlClearFault : 0) |
      (command.arm_latch ? kControlArmLatch : 0) | (command.latch_on_switch ? kControlLatchOnSwitch : 0));
  rpdo1.data[1] = command.alive_counter;
  put_setpoint(rpdo1.data, 2, raw[0]);
  out[0] = rpdo1;
  if (frame_count >= 2) {
    Frame rpdo2;
    rpdo2.id = setpoint_id(config, 1);
    rpdo2.dlc = kRpdo2Dlc;
    put_setpoint(rpdo2.data, 0, raw[1]);
    put_setpoint(rpdo2.data, 4, raw[2]);  // zero for L = 2
    out[1] = rpdo2;
  }
  if (frame_count >= 3) {
    Frame rpdo3;
    rpdo3.id = setpoint_id(config, 2);
    rpdo3.dlc = kRpdo3Dlc;
    put_setpoint(rpdo3.data, 0, raw[3]);
    out[2] = rpdo3;
  }
  status = CodecStatus::kOk;
  return frame_count;
}

CodecStatus decode_setpoint_frame(const ProtocolConfig& config, const Frame& frame,
                                  SetpointCommand& accumulate) noexcept {
  if (!config.is_valid()) return CodecStatus::kOutOfRange;
  const std::size_t frame_count = setpoint_frame_count(config.coil_sets);
  std::size_t index = kMaxSetpointFrames;
  for (std::size_t i = 0; i < frame_count; ++i) {
    if (frame.id == setpoint_id(config, i)) index = i;
  }
  if (index == kMaxSetpointFrames) return CodecStatus::kWrongId;
  constexpr std::array<std::uint8_t, kMaxSetpointFrames> dlcs{kRpdo1Dlc, kRpdo2Dlc, kRpdo3Dlc};
  if (frame.dlc != dlcs[index]) return CodecStatus::kWrongLength;

  if (index == 0) {
    const std::uint8_t control = frame.data[0];
    if ((control & kControlReservedMask) != 0) return CodecStatus::kOutOfRange;
    accumulate.enable = (control & kControlEnable) != 0;
    accumulate.clear_fault = (control & kControlClearFault) != 0;
    accumulate.arm_latch = (control & kControlArmLatch) != 0;
    accumulate.latch_on_switch = (control & kControlLatchOnSwitch) != 0;
    accumulate.alive_counter = frame.data[1];
    store_coil_set(config, frame.data, 2, 0, accumulate);
  } else if (index == 1) {
    if (config.coil_sets == 2 && get_unsigned_le(frame.data, 4, 4) != 0) return CodecStatus::kOutOfRange;
    store_coil_set(config, frame.data, 0, 1, accumulate);
    if (config.coil_sets >= 3) store_coil_set(config, frame.data, 4, 2, accumulate);
  } else {
    store_coil_set(config, frame.data, 0, 3, accumulate);
  }
  accumulate.coil_sets = config.coil_sets;
  return CodecStatus::kOk;
}

// --- Bus load ----------------------------------------------------------------

std::uint32_t cycle_bits(const ProtocolConfig& config) {
  config.validate();
  // The drive latch (TPDO2) is not in the schedule: an event frame, at most
  // one per arming of the latch (one per homing), not one per cycle.
  std::uint32_t bits = worst_case_frame_bits(kSyncDlc) + worst_case_frame_bits(kDriveFeedbackDlc);
  if (has_force_sensor(config)) bits += worst_case_frame_bits(kForceFeedbackDlc);
  constexpr std::array<std::uint8_t, kMaxSetpointFrames> dlcs{kRpdo1Dlc, kRpdo2Dlc, kRpdo3Dlc};
  for (std::size_t i = 0; i < setpoint_frame_count(config.coil_sets); ++i) bits += worst_case_frame_bits(dlcs[i]);
  return bits;
}

double bus_load(const ProtocolConfig& config, double bitrate_bps, double cycle_rate_hz) {
  require_positive_finite("bitrate_bps", bitrate_bps);
  require_positive_finite("cycle_rate_hz", cycle_rate_hz);
  return static_cast<double>(cycle_bits(config)) * cycle_rate_hz / bitrate_bps;
}

double check_bus_load(const ProtocolConfig& config, double bitrate_bps, double cycle_rate_hz, double limit) {
  if (!(limit > 0.0) || !(limit <= 1.0)) {
    throw std::invalid_argument("can bus load: limit must be in (0, 1], got " + format_number(limit));
  }
  const double load = bus_load(config, bitrate_bps, cycle_rate_hz);
  if (load > limit) {
    char text[256];
    std::snprintf(text, sizeof text,
                  "can bus load: %.1f %% exceeds the %.1f %% limit (%u worst-case bits per cycle for L = %d at "
                  "%.9g Hz on %.9g bit/s)",
                  100.0 * load, 100.0 * limit, static_cast<unsigned>(cycle_bits(config)), config.coil_sets,
                  cycle_rate_hz, bitrate_bps);
    throw std::invalid_argument(text);
  }
  return load;
}

std::string describe(const Frame& frame) {
  char text[64];
  int length = std::snprintf(text, sizeof text, "0x%03X [%u]", static_cast<unsigned>(frame.id),
                             static_cast<unsigned>(frame.dlc));
  const std::size_t bytes = frame.dlc < frame.data.size() ? frame.dlc : frame.data.size();
  for (std::size_t i = 0; i < bytes && length > 0 && static_cast<std::size_t>(length) < sizeof text; ++i) {
    length += std::snprintf(text + length, sizeof text - static_cast<std::size_t>(length), " %02X",
                            static_cast<unsigned>(frame.data[i]));
  }
  return text;
}

}  // namespace clm::can
