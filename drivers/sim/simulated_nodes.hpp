#pragma once
// The simulated motor as the drive and force-sensor nodes of the CAN
// protocol (docs/can-protocol.md). On each SYNC the nodes step the motor by
// one period, sample the encoder and the force sensor and reply; setpoint
// frames are collected until all of a cycle's RPDOs are in, then applied
// (a set still incomplete at the next SYNC is dropped). In the period the
// drive's position latch catches its event, the drive's latch frame (TPDO2)
// goes first, before its TPDO1.
// Used in-process (the daemon's embedded default) and, in `clm sim --can`,
// over SocketCAN. No allocation per frame.

#include <cstdint>
#include <span>

#include "drivers/can/can_protocol.hpp"
#include "drivers/sim/motor.hpp"

namespace clm::sim {

struct NodeCounters {
  std::int64_t syncs = 0;
  std::int64_t setpoints_applied = 0;
  std::int64_t setpoints_incomplete = 0;  ///< cycles whose RPDOs did not all arrive before the next SYNC: dropped
  std::int64_t frames_rejected = 0;       ///< undecodable frames addressed to the nodes
  std::int64_t feedback_not_encoded = 0;  ///< sensor values outside a signal's range: frame not sent
  std::int64_t replies_no_room = 0;       ///< replies that did not fit the caller's span: not sent
};

class SimulatedNodes {
 public:
  /// `motor` must outlive the nodes. `period_s` is the step per SYNC.
  SimulatedNodes(sim::SimulatedMotor& motor, const can::ProtocolConfig& protocol, double period_s);

  /// Room a caller's `replies` span needs for every reply to one frame:
  /// drive latch, drive feedback, force feedback.
  static constexpr std::size_t kMaxReplies = 3;

  /// Handles a frame from the bus; writes the nodes' replies to `replies`
  /// (room for kMaxReplies) and returns how many. With less room the cyclic
  /// feedback frames keep theirs: a latch frame that does not fit beside
  /// them is not sent, and is counted in replies_no_room (as is any frame
  /// that does not fit at all).
  std::size_t on_frame(const can::Frame& frame, std::span<can::Frame> replies) noexcept;

  const NodeCounters& counters() const noexcept { return counters_; }
  sim::SimulatedMotor& motor() noexcept { return *motor_; }
  const can::ProtocolConfig& protocol() const noexcept { return protocol_; }

 private:
  sim::SimulatedMotor* motor_;
  can::ProtocolConfig protocol_;
  double period_s_;
  can::SetpointCommand pending_{};
  unsigned received_mask_ = 0;
  std::uint8_t drive_alive_ = 0, force_alive_ = 0;
  std::uint8_t latch_count_ = 0;  ///< the drive latch frame's count: +1 per latch, wraps 255 → 0
  NodeCounters counters_;
};

}  // namespace clm::sim
