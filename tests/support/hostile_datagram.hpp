#pragma once
// Datagrams that once broke lcm-gen's decode, built from the real encoding so
// that only the hostile field differs from a well-formed message.

#include <cstdint>
#include <vector>

#include "clm_lcm/servo_command_t.hpp"

namespace clm::test {

/// A well-formed servo_command_t's encoding.
inline std::vector<std::uint8_t> encode_command(const clm_lcm::servo_command_t& command) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(command.getEncodedSize()));
  command.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

/// Offset of servo_command_t.program's length field for an empty axis:
/// hash, utime, sequence, axis (length and NUL), session, client, command,
/// four doubles.
inline constexpr std::size_t kCommandProgramLengthOffset = 8 + 8 + 8 + 5 + 8 + 8 + 1 + 4 * 8;

/// A MOVE_TO whose `program` length field is −2³¹ (the attack that once
/// crashed clm-servod, on the present layout): lcm-gen's decode computes
/// length − 1 and copies gigabytes past the buffer.
inline std::vector<std::uint8_t> program_length_min_int32_datagram() {
  clm_lcm::servo_command_t command{};
  command.axis = "";
  command.sequence = 1;
  command.command = clm_lcm::servo_command_t::MOVE_TO;
  command.program = std::string(26, 'p');
  command.path = "";
  std::vector<std::uint8_t> bytes = encode_command(command);
  const std::uint32_t length = 0x80000000u;
  for (int i = 0; i < 4; ++i) {
    bytes[kCommandProgramLengthOffset + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(length >> (24 - 8 * i));
  }
  return bytes;
}

}  // namespace clm::test
