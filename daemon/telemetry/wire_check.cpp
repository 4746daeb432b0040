#include "daemon/telemetry/wire_check.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "commutation/types.hpp"
#include "daemon/servo/command.hpp"
#include "daemon/telemetry/messages.hpp"

namespace clm::telemetry {
namespace {

constexpr double kAny = std::numeric_limits<double>::infinity();
constexpr double kMaxCoilSetCount = kMaxCoilSets;
/// Paths and program names in commands: PathText holds 255 characters.
constexpr double kMaxPathBytes = 255;
constexpr double kMaxParameterBytes = 47;  // servo::Command::parameter
/// Texts and paths the daemon sends; generous, but bounded.
constexpr double kMaxTextBytes = 4095;

constexpr WireField i8(const char* name, double min, double max) { return {WireKind::kInt8, name, min, max}; }
constexpr WireField i16(const char* name, double min = -kAny, double max = kAny) {
  return {WireKind::kInt16, name, min, max};
}
constexpr WireField i64(const char* name) { return {WireKind::kInt64, name, -kAny, kAny}; }
constexpr WireField boolean(const char* name) { return {WireKind::kBoolean, name, 0, 1}; }
constexpr WireField finite(const char* name) { return {WireKind::kDouble, name}; }
/// A measured value: NaN when there was no measurement.
constexpr WireField measured(const char* name) { return {WireKind::kDouble, name, 0, 0, true}; }
constexpr WireField text(const char* name, double max_bytes) { return {WireKind::kString, name, 0, max_bytes}; }
/// Counts in an array of fixed length: each one 0 or more.
constexpr WireField counts(const char* name, int length) {
  return {WireKind::kInt64FixedArray, name, 0, kAny, false, length};
}
/// The MAC: bytes of any value, always the last field (message_mac.hpp).
constexpr WireField mac() { return {WireKind::kByteFixedArray, "mac", 0, 255, false, 32}; }
constexpr WireField doubles(const char* name, int length_field) {
  return {WireKind::kDoubleArray, name, 0, 0, false, length_field};
}

constexpr double kCommutationMax = 5;
constexpr int kHistogramBins = static_cast<int>(kTimingHistogramBins);  // servo_state_t.COMMUTATION_EXPERIMENT

/// Axis names: 1..32 characters (config axis.name); 0 is let through here so
/// that the refusal names the axis rule rather than the layout.
constexpr double kMaxAxisBytes = 32;

constexpr std::array kCommandFields{
    i64("utime"), i64("sequence"), text("axis", kMaxAxisBytes), i64("session"), i64("client"), i8("command", 1, servo::kCommandKinds),
    finite("target_m"), finite("velocity_m_per_s"), finite("acceleration_m_per_s2"), finite("jerk_m_per_s3"),
    text("program", kMaxPathBytes), i8("commutation", 0, kCommutationMax), i8("coil_set", 0, kMaxCoilSetCount),
    finite("delta_rad"), text("path", kMaxPathBytes), text("parameter", kMaxParameterBytes), finite("value"), mac(),
};

constexpr std::array kAckFields{i64("utime"),   i64("sequence"),        text("axis", kMaxAxisBytes),
                                i64("session"), i64("client"),          boolean("accepted"),
                                text("text", kMaxTextBytes), mac()};

constexpr std::array kEventFields{i64("utime"), i64("cycle"), i16("code"), i8("severity", 0, 3),
                                  text("text", kMaxTextBytes), mac()};

constexpr std::array kStatusFields{
    i64("utime"), text("axis", kMaxAxisBytes), i64("session"), i8("state", 0, 2), i16("fault", 0),
    text("fault_reason", kMaxTextBytes), i64("fault_cycle"), i8("commutation", 0, kCommutationMax),
    text("calibration_file", kMaxTextBytes), text("calibration_sha256", 64), text("pgnn_model_file", kMaxTextBytes),
    text("pgnn_model_sha256", 64), text("spline_model_file", kMaxTextBytes), text("spline_model_sha256", 64),
    text("feedforward_file", kMaxTextBytes), text("feedforward_sha256", 64),
    text("configuration_file", kMaxTextBytes), text("configuration_sha256", 64), text("motor_file", kMaxTextBytes),
    text("motor_sha256", 64),
    finite("wakeup_latency_p50_s"), finite("wakeup_latency_p99_s"), finite("wakeup_latency_max_s"),
    finite("compute_time_p50_s"), finite("compute_time_p99_s"), finite("compute_time_max_s"),
    i64("overruns"), i64("cycles"), counts("wakeup_latency_histogram", kHistogramBins),
    counts("compute_time_histogram", kHistogramBins), i64("frames_sent"), i64("frames_received"), i64("frames_missing"),
    i64("frames_late"), i64("frames_rejected"), i64("telemetry_dropped"), i8("bus_state", -1, 3),
    i64("damping_cycles"), boolean("program_running"), finite("program_time_s"), boolean("restricted"),
    i8("force_sensor", 0, 2), i16("force_sensor_warning", 0), i64("force_sensor_losses"),
    i16("drive_signals", 0, 127), boolean("enabling"), i64("current_limited_cycles"), boolean("commutation_found"),
    boolean("homed"), i8("homing", 0, 4), finite("found_phase_rad"), finite("axis_offset_m"),
    i64("control_client"), finite("control_lease_remaining_s"), i64("commands_admitted"),
    i64("commands_refused_malformed"), i64("commands_refused_other_axis"), i64("commands_refused_other_session"),
    i64("commands_refused_no_client"), i64("commands_refused_replayed"), i64("commands_refused_stale"),
    i64("commands_refused_not_in_control"), i64("commands_refused_by_daemon"), i64("datagrams_dropped"),
    i64("commands_refused_unauthenticated"), mac(),
};

// Index 20 is coil_sets, the length of the four arrays after it.
constexpr int kStateCoilSets = 20;
constexpr std::array kStateFields{
    i64("utime"), i64("cycle"), finite("t_s"),
    finite("r_m"), finite("r_dot_m_per_s"), finite("r_ddot_m_per_s2"), measured("y_m"), measured("e_m"),
    finite("F_star_N"), finite("u_fb_N"), finite("u_ff_N"),
    finite("Fy_star_N"), finite("Fx_star_N"), finite("Tz_star_Nm"), measured("Fy_N"), measured("Fx_N"), measured("Tz_Nm"),
    i8("commutation", 0, kCommutationMax), i8("coil_set", 0, kMaxCoilSetCount), finite("delta_rad"),
    i8("coil_sets", 0, kMaxCoilSetCount),
    doubles("magnitude_N", kStateCoilSets), doubles("setpoint_delta_rad", kStateCoilSets),
    doubles("ia_A", kStateCoilSets), doubles("ib_A", kStateCoilSets),
    boolean("damping_engaged"), finite("current_square_sum_A2"), boolean("force_limited"),
    i8("state", 0, 2), boolean("program_running"), finite("program_time_s"), boolean("restricted"),
    boolean("force_measured"),
    i8("drive_profile", 0, 1), mac(),
};
static_assert(kStateFields[kStateCoilSets].kind == WireKind::kInt8);

std::uint64_t read_big_endian(const std::uint8_t* p, std::size_t bytes) noexcept {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < bytes; ++i) value = (value << 8) | p[i];
  return value;
}

std::int64_t read_signed(const std::uint8_t* p, std::size_t bytes) noexcept {
  const std::uint64_t raw = read_big_endian(p, bytes);
  const unsigned shift = static_cast<unsigned>(64 - 8 * bytes);
  // Sign-extend through the top bits.
  return static_cast<std::int64_t>(raw << shift) >> shift;
}

double read_double(const std::uint8_t* p) noexcept {
  const std::uint64_t raw = read_big_endian(p, 8);
  double value = 0.0;
  std::memcpy(&value, &raw, sizeof value);
  return value;
}

std::size_t width(WireKind kind) noexcept {
  switch (kind) {
    case WireKind::kInt8:
    case WireKind::kBoolean: return 1;
    case WireKind::kInt16: return 2;
    case WireKind::kInt32: return 4;
    case WireKind::kInt64:
    case WireKind::kDouble: return 8;
    case WireKind::kString:
    case WireKind::kDoubleArray:
    case WireKind::kInt64FixedArray:
    case WireKind::kByteFixedArray: return 0;
  }
  return 0;
}

std::string number_text(double value) {
  if (std::isnan(value)) return "nan";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

}  // namespace

#define CLM_WIRE_LAYOUT(Message, fields)                                              \
  const WireLayout& wire_layout(const clm_lcm::Message*) {                            \
    static const WireLayout layout{#Message, clm_lcm::Message::getHash(), fields};    \
    return layout;                                                                    \
  }
CLM_WIRE_LAYOUT(servo_command_t, kCommandFields)
CLM_WIRE_LAYOUT(servo_command_ack_t, kAckFields)
CLM_WIRE_LAYOUT(servo_state_t, kStateFields)
CLM_WIRE_LAYOUT(servo_status_t, kStatusFields)
CLM_WIRE_LAYOUT(servo_event_t, kEventFields)
#undef CLM_WIRE_LAYOUT

std::size_t max_wire_bytes(const WireLayout& layout) noexcept {
  std::size_t bytes = 8;  // the hash
  for (const WireField& field : layout.fields) {
    switch (field.kind) {
      case WireKind::kString: bytes += 4 + static_cast<std::size_t>(field.max) + 1; break;
      case WireKind::kDoubleArray:
        bytes += 8 * static_cast<std::size_t>(layout.fields[static_cast<std::size_t>(field.length_field)].max);
        break;
      case WireKind::kInt64FixedArray: bytes += 8 * static_cast<std::size_t>(field.length_field); break;
      case WireKind::kByteFixedArray: bytes += static_cast<std::size_t>(field.length_field); break;
      default: bytes += width(field.kind); break;
    }
  }
  return bytes;
}

std::string check_wire(const WireLayout& layout, std::span<const std::uint8_t> datagram) {
  const std::string_view type = layout.type_name;
  const std::size_t size = datagram.size();
  if (size < 8) return std::string(type) + ": datagram of " + std::to_string(size) + " bytes is shorter than the type hash";
  if (read_signed(datagram.data(), 8) != layout.hash) return std::string(type) + ": type hash does not match";
  std::size_t pos = 8;
  // Integer fields seen so far, for the lengths of arrays.
  std::array<std::int64_t, 96> integers{};
  if (layout.fields.size() > integers.size()) return std::string(type) + ": layout has too many fields";
  for (std::size_t f = 0; f < layout.fields.size(); ++f) {
    const WireField& field = layout.fields[f];
    // Built only for a refusal: the accepted path does not allocate.
    const auto where = [&] { return std::string(type) + "." + field.name; };
    const std::size_t bytes = width(field.kind);
    if (bytes > 0 && size - pos < bytes) return where() + ": datagram ends inside the field";
    const std::uint8_t* p = datagram.data() + pos;
    switch (field.kind) {
      case WireKind::kInt8:
      case WireKind::kInt16:
      case WireKind::kInt32:
      case WireKind::kInt64:
      case WireKind::kBoolean: {
        const std::int64_t value = read_signed(p, bytes);
        const double as_double = static_cast<double>(value);
        if (as_double < field.min || as_double > field.max) {
          return where() + ": " + std::to_string(value) + " is outside [" + number_text(field.min) + ", " +
                 number_text(field.max) + "]";
        }
        integers[f] = value;
        pos += bytes;
        break;
      }
      case WireKind::kDouble: {
        const double value = read_double(p);
        if (std::isinf(value) || (std::isnan(value) && !field.nan_allowed)) {
          return where() + ": " + number_text(value) + " is not a finite number";
        }
        pos += bytes;
        break;
      }
      case WireKind::kString: {
        if (size - pos < 4) return where() + ": datagram ends inside the string length";
        const std::int64_t length = read_signed(p, 4);  // includes the NUL
        if (length < 1) return where() + ": string length " + std::to_string(length) + " is below 1";
        if (static_cast<double>(length - 1) > field.max) {
          return where() + ": string of " + std::to_string(length - 1) + " bytes is over the limit of " +
                 number_text(field.max);
        }
        if (static_cast<std::uint64_t>(length) > size - pos - 4) {
          return where() + ": string of " + std::to_string(length - 1) + " bytes runs past the datagram";
        }
        const std::uint8_t* chars = p + 4;
        if (chars[length - 1] != 0) return where() + ": string is not NUL-terminated";
        for (std::int64_t i = 0; i + 1 < length; ++i) {
          if (chars[i] < 0x20 || chars[i] == 0x7f) {
            return where() + ": control character at byte " + std::to_string(i);
          }
        }
        pos += 4 + static_cast<std::size_t>(length);
        break;
      }
      case WireKind::kDoubleArray: {
        const std::int64_t count = integers[static_cast<std::size_t>(field.length_field)];
        if (count < 0 || static_cast<std::uint64_t>(count) > (size - pos) / 8) {
          return where() + ": " + std::to_string(count) + " elements run past the datagram";
        }
        for (std::int64_t i = 0; i < count; ++i) {
          const double value = read_double(p + 8 * i);
          if (!std::isfinite(value)) return where() + "[" + std::to_string(i) + "]: " + number_text(value) + " is not finite";
        }
        pos += 8 * static_cast<std::size_t>(count);
        break;
      }
      case WireKind::kInt64FixedArray: {
        const auto count = static_cast<std::size_t>(field.length_field);
        if (count > (size - pos) / 8) return where() + ": datagram ends inside the array";
        for (std::size_t i = 0; i < count; ++i) {
          const std::int64_t value = read_signed(p + 8 * i, 8);
          if (static_cast<double>(value) < field.min || static_cast<double>(value) > field.max) {
            return where() + "[" + std::to_string(i) + "]: " + std::to_string(value) + " is outside [" +
                   number_text(field.min) + ", " + number_text(field.max) + "]";
          }
        }
        pos += 8 * count;
        break;
      }
      case WireKind::kByteFixedArray: {
        const auto count = static_cast<std::size_t>(field.length_field);
        if (count > size - pos) return where() + ": datagram ends inside the array";
        pos += count;
        break;
      }
    }
  }
  if (pos != size) return std::string(type) + ": " + std::to_string(size - pos) + " bytes after the last field";
  return "";
}

}  // namespace clm::telemetry
