#pragma once
// The CAN bus as the daemon and the simulated nodes see it: send a frame,
// receive one before a deadline, and the controller's error state.
// Implementations: SocketCanBus (drivers/socket_can_bus.hpp); test doubles
// live under tests/.

#include <cstdint>

#include "drivers/can/can_protocol.hpp"

namespace clm::drivers {

/// A frame and when it was received.
struct ReceivedFrame {
  clm::can::Frame frame;
  std::int64_t timestamp_ns = 0;  ///< reception time, CLOCK_MONOTONIC [ns]
};

/// Error state of the CAN controller (ISO 11898-1 fault confinement).
enum class BusState {
  kActive,        ///< error counters below 96: normal operation
  kErrorWarning,  ///< an error counter reached 96
  kErrorPassive,  ///< an error counter reached 128: the node may no longer send active error flags
  kBusOff,        ///< transmit error counter above 255: the controller is off the bus until restarted
};

/// "active", "error warning", "error passive", "bus off".
const char* to_string(BusState state) noexcept;

/// One CAN bus. send and receive run in the cycle: noexcept, no allocation.
class CanBus {
 public:
  virtual ~CanBus();
  /// Queues `frame` for transmission; false if it could not be queued (queue
  /// full, interface down, frame invalid). Never blocks.
  virtual bool send(const clm::can::Frame& frame) noexcept = 0;
  /// Waits until a data frame arrives or until `deadline_ns` (CLOCK_MONOTONIC
  /// [ns]) passes; true with the frame in `out`, false on the deadline with
  /// nothing read (`out` untouched). A deadline in the past still returns a
  /// frame that is already waiting.
  virtual bool receive(ReceivedFrame& out, std::int64_t deadline_ns) noexcept = 0;
  /// The controller's error state as last reported.
  virtual BusState state() const noexcept = 0;
  /// Error frames seen since construction.
  virtual std::uint64_t error_frames() const noexcept = 0;
};

}  // namespace clm::drivers
