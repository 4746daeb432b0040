// libFuzzer harness: the CAN frame decoders of drivers/can_protocol.hpp.
//
// Input bytes: [0] drive node ID, [1] force-sensor node ID, [2] coil sets
// (signed), [3..4] identifier (little-endian, not masked to 11 bits), [5] DLC
// (any 0..255), [6..13] payload; missing bytes are zero. Every decoder sees
// the frame, the setpoint decoder for both drive profiles. Invariants: a decoder that refuses writes nothing; one that
// accepts gives values that the matching encoder turns back into the same
// frame (identifier, DLC, the DLC's payload bytes).

#include <algorithm>
#include <array>
#include <cstring>

#include "drivers/can/can_protocol.hpp"
#include "fuzz_support.hpp"

namespace can = clm::can;
using clm::fuzz::require;

namespace {

bool same_frame(const can::Frame& a, const can::Frame& b) {
  if (a.id != b.id || a.dlc != b.dlc) return false;
  const std::size_t bytes = std::min<std::size_t>(a.dlc, a.data.size());
  return std::equal(a.data.begin(), a.data.begin() + static_cast<std::ptrdiff_t>(bytes), b.data.begin());
}

void check_sync(const can::Frame& frame) {
  std::uint8_t counter = 77;
  const can::CodecStatus status = can::decode_sync(frame, counter);
  if (status != can::CodecStatus::kOk) {
    require(counter == 77, "decode_sync wrote on refusal", can::describe(frame));
    return;
  }
  can::Frame again;
  require(can::encode_sync(counter, again) == can::CodecStatus::kOk, "encode_sync refused a decoded counter",
          can::describe(frame));
  require(same_frame(frame, again), "SYNC does not round-trip", can::describe(frame) + " vs " + can::describe(again));
  require(can::next_sync_counter(counter) >= can::kSyncCounterFirst &&
              can::next_sync_counter(counter) <= can::kSyncCounterLast,
          "next_sync_counter left 1..240");
}

void check_drive_feedback(const can::ProtocolConfig& config, const can::Frame& frame) {
  can::DriveFeedback feedback;
  feedback.position_m = 12.5;
  feedback.status_word = 0xABCD;
  feedback.alive_counter = 77;
  const can::CodecStatus status = can::decode_drive_feedback(config, frame, feedback);
  if (status != can::CodecStatus::kOk) {
    require(feedback.position_m == 12.5 && feedback.status_word == 0xABCD && feedback.alive_counter == 77,
            "decode_drive_feedback wrote on refusal", can::describe(frame));
    return;
  }
  can::Frame again;
  require(can::encode_drive_feedback(config, feedback, again) == can::CodecStatus::kOk,
          "encode_drive_feedback refused decoded values", can::describe(frame));
  require(same_frame(frame, again), "drive feedback does not round-trip",
          can::describe(frame) + " vs " + can::describe(again));
}

void check_force_feedback(const can::ProtocolConfig& config, const can::Frame& frame) {
  can::ForceFeedback feedback;
  feedback.wrench << 1.5, 2.5, 3.5;
  feedback.alive_counter = 77;
  const can::CodecStatus status = can::decode_force_feedback(config, frame, feedback);
  if (status != can::CodecStatus::kOk) {
    require(feedback.wrench[0] == 1.5 && feedback.wrench[1] == 2.5 && feedback.wrench[2] == 3.5 &&
                feedback.alive_counter == 77,
            "decode_force_feedback wrote on refusal", can::describe(frame));
    return;
  }
  can::Frame again;
  require(can::encode_force_feedback(config, feedback, again) == can::CodecStatus::kOk,
          "encode_force_feedback refused decoded values", can::describe(frame));
  require(same_frame(frame, again), "force feedback does not round-trip",
          can::describe(frame) + " vs " + can::describe(again));
}

bool same_command(const can::SetpointCommand& a, const can::SetpointCommand& b) {
  if (a.enable != b.enable || a.clear_fault != b.clear_fault || a.alive_counter != b.alive_counter ||
      a.coil_sets != b.coil_sets) {
    return false;
  }
  for (std::size_t l = 0; l < a.setpoints.size(); ++l) {
    if (a.setpoints[l].magnitude_N != b.setpoints[l].magnitude_N || a.setpoints[l].delta_rad != b.setpoints[l].delta_rad) {
      return false;
    }
    if (a.currents[l].ia_A != b.currents[l].ia_A || a.currents[l].ib_A != b.currents[l].ib_A) return false;
  }
  return true;
}

void check_setpoint_frame(const can::ProtocolConfig& config, const can::Frame& frame) {
  can::SetpointCommand command;  // all zero: the other frames' fields encode as zero
  const can::SetpointCommand before = command;
  const can::CodecStatus status = can::decode_setpoint_frame(config, frame, command);
  if (status != can::CodecStatus::kOk) {
    require(same_command(command, before), "decode_setpoint_frame wrote on refusal", can::describe(frame));
    return;
  }
  require(command.coil_sets == config.coil_sets, "decode_setpoint_frame set another L", can::describe(frame));
  std::array<can::Frame, can::kMaxSetpointFrames> frames{};
  can::CodecStatus encoded = can::CodecStatus::kWrongId;
  const std::size_t count = can::encode_setpoints(config, command, frames, encoded);
  require(encoded == can::CodecStatus::kOk && count == can::setpoint_frame_count(config.coil_sets),
          "encode_setpoints refused decoded values", can::describe(frame));
  bool found = false;
  for (std::size_t i = 0; i < count; ++i) {
    if (frames[i].id != frame.id) continue;
    found = true;
    require(same_frame(frame, frames[i]), "setpoint frame does not round-trip",
            can::describe(frame) + " vs " + can::describe(frames[i]));
  }
  require(found, "decoded setpoint frame has no encoded counterpart", can::describe(frame));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::array<std::uint8_t, 14> bytes{};
  std::memcpy(bytes.data(), data, std::min(size, bytes.size()));

  can::ProtocolConfig config;
  config.drive_node_id = bytes[0];
  config.force_sensor_node_id = bytes[1];
  config.coil_sets = static_cast<std::int8_t>(bytes[2]);
  can::Frame frame;
  frame.id = static_cast<std::uint32_t>(bytes[3] | (bytes[4] << 8));
  frame.dlc = bytes[5];
  std::copy(bytes.begin() + 6, bytes.end(), frame.data.begin());

  require(!can::describe(frame).empty(), "describe gave no text");
  check_sync(frame);
  check_drive_feedback(config, frame);
  check_force_feedback(config, frame);
  check_setpoint_frame(config, frame);
  config.drive_profile = clm::DriveProfile::kPhaseCurrent;  // the same frame as phase currents
  check_setpoint_frame(config, frame);
  return 0;
}
