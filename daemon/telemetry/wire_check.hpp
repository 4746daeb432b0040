#pragma once
// Checks an LCM datagram against the layout of its message type before
// lcm-gen's decode runs. lcm-gen's C++ decode trusts the lengths it reads: a
// string length of 0 or below, or a negative array length, makes it copy or
// allocate gigabytes. Every message the daemon and its clients read from the
// network goes through decode_checked(), which walks the encoding field by
// field and refuses, before any decode:
//  - a datagram shorter or longer than its fields, or with another type's hash;
//  - a string whose length is < 1, beyond the datagram, over the field's
//    limit, without its terminating NUL, or with a control character;
//  - an array whose length field is outside its range;
//  - an integer (enum, counter, flag, histogram count) outside the field's range;
//  - a non-finite number where the field must be finite.
// The layouts are written here from lcmtypes/*.lcm; a test checks each one
// against lcm-gen's encoding of random messages.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "clm_lcm/servo_command_ack_t.hpp"
#include "clm_lcm/servo_command_t.hpp"
#include "clm_lcm/servo_event_t.hpp"
#include "clm_lcm/servo_state_t.hpp"
#include "clm_lcm/servo_status_t.hpp"

namespace clm::telemetry {

enum class WireKind : std::uint8_t {
  kInt8, kInt16, kInt32, kInt64, kBoolean, kDouble, kString, kDoubleArray, kInt64FixedArray, kByteFixedArray
};

/// One field of an LCM struct, in encoding order.
struct WireField {
  WireKind kind;
  const char* name;
  /// kInt*, kInt64FixedArray: accepted range (of each element). kString:
  /// longest accepted length in bytes, without the NUL (in `max`).
  /// kDoubleArray: unused.
  double min = 0.0;
  double max = 0.0;
  /// kDouble, kDoubleArray: NaN is accepted (infinities never are).
  bool nan_allowed = false;
  /// kDoubleArray: index of the earlier integer field that holds the length.
  /// kInt64FixedArray, kByteFixedArray: the length itself.
  int length_field = -1;
};

/// A message type's layout: its hash and its fields.
struct WireLayout {
  const char* type_name;
  std::int64_t hash;
  std::span<const WireField> fields;
};

const WireLayout& wire_layout(const clm_lcm::servo_command_t*);
const WireLayout& wire_layout(const clm_lcm::servo_command_ack_t*);
const WireLayout& wire_layout(const clm_lcm::servo_state_t*);
const WireLayout& wire_layout(const clm_lcm::servo_status_t*);
const WireLayout& wire_layout(const clm_lcm::servo_event_t*);

/// The longest encoding `layout` accepts [bytes]: hash, every string at its
/// limit with its length and NUL, every array at its longest.
std::size_t max_wire_bytes(const WireLayout& layout) noexcept;

/// Walks `datagram` against `layout`. Returns "" when it fits exactly, else a
/// one-line reason naming the field and the offending value (never the
/// datagram's text). Does not allocate on success.
std::string check_wire(const WireLayout& layout, std::span<const std::uint8_t> datagram);

/// check_wire, then lcm-gen's decode. Returns "" on success (and `out` holds
/// the message), else the reason; `out` is unspecified then.
template <typename Message>
std::string decode_checked(std::span<const std::uint8_t> datagram, Message& out) {
  std::string reason = check_wire(wire_layout(static_cast<const Message*>(nullptr)), datagram);
  if (!reason.empty()) return reason;
  const int size = static_cast<int>(datagram.size());
  if (out.decode(datagram.data(), 0, size) != size) return std::string(out.getTypeName()) + ": decode failed";
  return "";
}

}  // namespace clm::telemetry
