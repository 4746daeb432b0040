#pragma once
// Frame helpers of the CAN protocol tests (test_can_protocol.cpp,
// test_phase_current_protocol.cpp).

#include <cstddef>
#include <cstdint>
#include <initializer_list>

#include "drivers/can/can_protocol.hpp"

namespace clm::test {

/// A frame full of a pattern no encoder writes, to prove nothing was written.
inline can::Frame sentinel_frame() {
  can::Frame frame;
  frame.id = 0x7AB;
  frame.dlc = 3;
  frame.data.fill(0xA5);
  return frame;
}

inline bool same_frame(const can::Frame& a, const can::Frame& b) {
  return a.id == b.id && a.dlc == b.dlc && a.data == b.data;
}

/// A frame of identifier `id` with `bytes` as its data (DLC their count).
inline can::Frame frame_of(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  can::Frame frame;
  frame.id = id;
  frame.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (const auto byte : bytes) frame.data[i++] = byte;
  return frame;
}

}  // namespace clm::test
