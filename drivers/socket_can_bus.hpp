#pragma once
// CanBus on Linux SocketCAN: a raw CAN socket bound to one interface.
//
// - Receive filters pass exactly the standard-ID data frames the owner consumes
//   (no extended, no remote frames); error frames are enabled
//   (CAN_RAW_ERR_FILTER = CAN_ERR_MASK) and turned into BusState and a count.
// - Non-blocking socket; receive() reads with recvmsg and waits with ppoll
//   until the deadline.
// - Timestamps: SO_TIMESTAMPNS, the kernel's software receive time (the
//   moment the driver handed the frame to the network stack), which the
//   kernel gives in CLOCK_REALTIME. It is moved to CLOCK_MONOTONIC by
//   subtracting the REALTIME − MONOTONIC offset sampled right after the read;
//   a step of the wall clock between reception and read would shift that one
//   timestamp by the step. Without a timestamp in the message, the read time.
// - SO_RXQ_OVFL: frames the kernel dropped because the socket's queue was
//   full are counted (dropped_frames()).
// send and receive do not allocate or throw.

#include <atomic>
#include <cstdint>
#include <span>
#include <string>

#include "drivers/can_bus.hpp"

namespace clm::drivers {

class SocketCanBus final : public CanBus {
 public:
  /// Opens a raw CAN socket on `interface_name` (e.g. "can0", "vcan0") that
  /// receives only the standard (11-bit) data frames with the given
  /// identifiers. Throws std::invalid_argument if an identifier exceeds 0x7FF,
  /// std::runtime_error naming the interface and the errno text if the kernel
  /// has no SocketCAN ("... (this kernel has no SocketCAN)"), the interface
  /// does not exist, is not a CAN interface, is down, or a socket option fails.
  SocketCanBus(const std::string& interface_name, std::span<const std::uint32_t> receive_ids);
  ~SocketCanBus() override;
  SocketCanBus(const SocketCanBus&) = delete;
  SocketCanBus& operator=(const SocketCanBus&) = delete;

  bool send(const clm::can::Frame& frame) noexcept override;
  bool receive(ReceivedFrame& out, std::int64_t deadline_ns) noexcept override;
  BusState state() const noexcept override { return state_.load(std::memory_order_relaxed); }
  std::uint64_t error_frames() const noexcept override { return error_frames_.load(std::memory_order_relaxed); }

  /// Frames the kernel dropped for this socket because its receive queue was full.
  std::uint64_t dropped_frames() const noexcept { return dropped_frames_.load(std::memory_order_relaxed); }
  /// Errors the socket reported on reads or waits (e.g. ENETDOWN when the interface goes down).
  std::uint64_t socket_errors() const noexcept { return socket_errors_.load(std::memory_order_relaxed); }
  const std::string& interface_name() const noexcept { return interface_name_; }

 private:
  void handle_error_frame(std::uint32_t can_id, const std::uint8_t* data) noexcept;

  std::string interface_name_;
  int fd_ = -1;
  std::atomic<BusState> state_{BusState::kActive};
  std::atomic<std::uint64_t> error_frames_{0};
  std::atomic<std::uint64_t> dropped_frames_{0};
  std::atomic<std::uint64_t> socket_errors_{0};
};

/// The state after an error frame whose class bits (can_id & CAN_ERR_MASK) are
/// `error_class` and whose data[1] (controller status, CAN_ERR_CRTL_*) is
/// `controller_status`: CAN_ERR_BUSOFF → kBusOff; CAN_ERR_RESTARTED → kActive;
/// with CAN_ERR_CRTL: RX/TX passive → kErrorPassive, RX/TX warning →
/// kErrorWarning, CAN_ERR_CRTL_ACTIVE → kActive (the kernel reports the new
/// state, also when it falls). Other errors (protocol, ACK, arbitration, buffer
/// overflows) leave the state as it is; so does anything but a restart or
/// CRTL_ACTIVE while bus-off.
BusState bus_state_after_error(BusState current, std::uint32_t error_class, std::uint8_t controller_status) noexcept;

}  // namespace clm::drivers
