#pragma once
// A small reader of the DBC subset drivers/can/clm-servo.dbc uses (BU_, BO_, SG_
// lines; comments and attributes skipped), and bit packing by a DBC signal
// description. Test code only: it is how the tests hold the DBC against the codec.

#include <cstdint>
#include <string>
#include <vector>

#include "drivers/can/can_protocol.hpp"

namespace clm::test {

struct DbcSignal {
  std::string name;
  int start_bit = 0;        ///< Intel: bit of the LSB, counted byte 0 bit 0 = 0
  int length_bits = 0;
  bool little_endian = true;  ///< @1 (Intel); @0 (Motorola) is read but the tests expect @1
  bool is_signed = false;     ///< '-' in the DBC
  double scale = 1.0;
  double offset = 0.0;
  double minimum = 0.0;
  double maximum = 0.0;
  std::string unit;
  std::vector<std::string> receivers;

  /// Raw (integer) limits of [minimum, maximum].
  std::int64_t raw_minimum() const;
  std::int64_t raw_maximum() const;
};

struct DbcMessage {
  std::uint32_t id = 0;
  std::string name;
  int dlc = 0;
  std::string sender;
  std::vector<DbcSignal> signals;
};

struct DbcFile {
  std::vector<std::string> nodes;
  std::vector<DbcMessage> messages;
};

/// Parses `path`; throws std::runtime_error "path:line: ..." on a malformed BO_ or SG_ line.
DbcFile read_dbc(const std::string& path);

/// The raw value of `signal` in `frame` (sign-extended if signed).
std::int64_t extract_raw(const DbcSignal& signal, const clm::can::Frame& frame);
/// Writes the low length_bits of `raw` at the signal's bits of `frame`.
void insert_raw(const DbcSignal& signal, std::int64_t raw, clm::can::Frame& frame);

}  // namespace clm::test
