#include "drivers/sim/in_process_bus.hpp"

namespace clm::sim {

InProcessBus::InProcessBus(SimulatedNodes& nodes) : nodes_(&nodes) {}

void InProcessBus::enqueue(const can::Frame& frame, std::int64_t stamp_ns) noexcept {
  if (tail_ - head_ >= kCapacity) return;  // full: the frame is lost, as on a real bus
  ring_[tail_ % kCapacity] = {frame, stamp_ns};
  ++tail_;
}

bool InProcessBus::send(const can::Frame& frame) noexcept {
  if (frame.id == can::kSyncId) monitor_count_ = 0;  // a new cycle, even if its SYNC is refused
  if (injection_.fail_sends) return false;
  if (frame.id != can::kSyncId && monitor_count_ < monitor_.size()) monitor_[monitor_count_++] = frame;
  if (frame.id != can::kSyncId && injection_.drop_setpoint_frames > 0) {
    --injection_.drop_setpoint_frames;
    return true;  // sent, but lost on the way
  }
  if (frame.id == can::kSyncId) {
    // Frames held back last cycle arrive now, stamped before this SYNC.
    for (std::size_t k = 0; k < delayed_count_; ++k) enqueue(delayed_[k].frame, delayed_[k].timestamp_ns);
    delayed_count_ = 0;
  }
  std::array<can::Frame, 2> replies{};
  const std::size_t count = nodes_->on_frame(frame, replies);
  const can::ProtocolConfig& protocol = nodes_->protocol();
  for (std::size_t k = 0; k < count; ++k) {
    can::Frame reply = replies[k];
    if (reply.id == can::drive_feedback_id(protocol)) {
      Injection& in = injection_;
      if (in.drop_drive_frames > 0) {
        --in.drop_drive_frames;
        continue;
      }
      if (in.skip_drive_alive != 0) {
        reply.data[6] = static_cast<std::uint8_t>(reply.data[6] + in.skip_drive_alive);
        in.skip_drive_alive = 0;
      }
      if (in.wrong_dlc_drive_frames > 0) {
        --in.wrong_dlc_drive_frames;
        reply.dlc = 5;
      }
      if (in.corrupt_position_frames > 0) {
        --in.corrupt_position_frames;
        reply.data[0] = 0xff;
        reply.data[1] = 0xff;
        reply.data[2] = 0xff;
        reply.data[3] = 0x7f;
      }
      if (in.delay_drive_frames > 0 && delayed_count_ < delayed_.size()) {
        --in.delay_drive_frames;
        delayed_[delayed_count_++] = {reply, time_ns_};
        continue;
      }
      enqueue(reply, time_ns_);
      if (in.duplicate_drive_frames > 0) {
        --in.duplicate_drive_frames;
        enqueue(reply, time_ns_);
      }
      continue;
    }
    if (reply.id == can::force_feedback_id(protocol)) {
      if (injection_.drop_force_frames > 0) {
        --injection_.drop_force_frames;
        continue;
      }
      if (injection_.skip_force_alive != 0) {
        reply.data[7] = static_cast<std::uint8_t>(reply.data[7] + injection_.skip_force_alive);
        injection_.skip_force_alive = 0;
      }
    }
    enqueue(reply, time_ns_);
  }
  return true;
}

bool InProcessBus::receive(drivers::ReceivedFrame& out, std::int64_t /*deadline_ns*/) noexcept {
  if (head_ == tail_) return false;
  out = ring_[head_ % kCapacity];
  ++head_;
  return true;
}

}  // namespace clm::sim
