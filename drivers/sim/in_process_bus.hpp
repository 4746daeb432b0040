#pragma once
// The embedded default bus (`can.interface: sim`): the daemon's frames go
// straight to the simulated nodes and their replies come back through a
// fixed ring, timestamped with the loop's clock (the bus is its own
// drivers::BusClock). Optional fault injection acts on the frames as a
// bus-side injector would.

#include <array>
#include <cstdint>
#include <span>

#include "drivers/bus_clock.hpp"
#include "drivers/can_bus.hpp"
#include "drivers/sim/simulated_nodes.hpp"

namespace clm::sim {

/// Bus-side fault injection on the in-process bus (docs/reliability.md).
struct Injection {
  int drop_drive_frames = 0;       ///< drop the next n drive feedback frames
  int drop_force_frames = 0;       ///< drop the next n force-sensor frames
  int delay_drive_frames = 0;      ///< deliver the next n drive frames one cycle late
  int duplicate_drive_frames = 0;  ///< deliver the next n drive frames twice
  int wrong_dlc_drive_frames = 0;  ///< next n drive frames with DLC 5
  int skip_drive_alive = 0;        ///< add this to the next drive frame's alive counter
  int skip_force_alive = 0;        ///< add this to the next force-sensor frame's alive counter
  int corrupt_position_frames = 0; ///< next n drive frames with the position bytes set to 0x7fffffff
  int drop_setpoint_frames = 0;    ///< drop the next n setpoint frames (the drive watchdog sees nothing)
  drivers::BusState bus_state = drivers::BusState::kActive;
  bool fail_sends = false;
};

class InProcessBus final : public drivers::CanBus, public drivers::BusClock {
 public:
  explicit InProcessBus(SimulatedNodes& nodes);

  /// Time stamped on replies [ns]; the loop sets it to the SYNC time.
  void advance_to(std::int64_t time_ns) noexcept override { time_ns_ = time_ns; }
  Injection& injection() noexcept { return injection_; }

  bool send(const can::Frame& frame) noexcept override;
  /// Returns a waiting reply at once, or false: nothing else can arrive in-process.
  bool receive(drivers::ReceivedFrame& out, std::int64_t deadline_ns) noexcept override;
  drivers::BusState state() const noexcept override { return injection_.bus_state; }
  std::uint64_t error_frames() const noexcept override { return 0; }

  /// Bus monitor beside the daemon: the frames it transmitted since it last
  /// sent (or tried to send) a SYNC, in order, SYNC itself excluded. A frame counts once send()
  /// accepted it, even if the injection then lost it on the way to the
  /// drive; frames refused by `fail_sends` are not on the bus. For tests.
  std::span<const can::Frame> frames_since_sync() const noexcept { return {monitor_.data(), monitor_count_}; }

 private:
  void enqueue(const can::Frame& frame, std::int64_t stamp_ns) noexcept;
  SimulatedNodes* nodes_;
  std::int64_t time_ns_ = 0;
  Injection injection_;
  static constexpr std::size_t kCapacity = 64;
  std::array<drivers::ReceivedFrame, kCapacity> ring_{};
  std::size_t head_ = 0, tail_ = 0;
  std::array<drivers::ReceivedFrame, 8> delayed_{};
  std::size_t delayed_count_ = 0;
  std::array<can::Frame, 8> monitor_{};
  std::size_t monitor_count_ = 0;
};

}  // namespace clm::sim
