#pragma once
// The embedded default bus (`can.interface: sim`): the daemon's frames go
// straight to the simulated nodes and their replies come back through a
// fixed ring, timestamped with the loop's clock (the bus is its own
// drivers::BusClock). Optional fault injection acts on the frames as a
// bus-side injector would; the drive's latch frame (TPDO2) is passed on as
// the nodes sent it, in its period and before the drive feedback.

#include <array>
#include <atomic>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

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
  int drop_latch_frames = 0;       ///< drop the next n latch frames of the drive
  /// At the next SYNC, a latch frame no latch made, naming this reading: a
  /// frame from another node on the bus, or one corrupted into a valid one.
  bool spoof_latch = false;
  double spoof_latch_position_m = 0.0;
  drivers::BusState bus_state = drivers::BusState::kActive;
  bool fail_sends = false;
};

/// A step of the in-process bus's injection plan (servod config
/// can.sim_fault_plan, docs/reliability.md), fired on request at the next SYNC.
enum class PlannedFault {
  kDropDrive,          ///< "drop-drive:N": the next N drive frames are lost
  kDropForce,          ///< "drop-force:N"
  kLateDrive,          ///< "late-drive:N": the next N drive frames arrive a cycle late
  kDuplicate,          ///< "duplicate:N": the next N drive frames arrive twice
  kWrongDlc,           ///< "wrong-dlc:N": the next N drive frames with DLC 5
  kCorruptAlive,       ///< "corrupt-alive": the drive's alive counter jumps by 7
  kCorruptForceAlive,  ///< "corrupt-force-alive": the force sensor's alive counter jumps by 7
  kCorruptPosition,    ///< "corrupt-position:N": position bytes 0x7fffffff in the next N drive frames
  kDropSetpoints,      ///< "drop-setpoints:N": the next N setpoint frames are lost (the drive watchdog)
  kDriveFault,         ///< "drive-fault": the drive latches a fault of its own
  kBusOff,             ///< "bus-off:N": the controller reports bus-off for N cycles
  kErrorPassive,       ///< "error-passive:N"
  kFailSends,          ///< "fail-sends:N": no frame can be queued for N cycles
  kPush,               ///< "push:N:F": F newtons against the motion on the translator for N cycles,
                       ///< ended early when the drive is disabled (the fixture lets go)
  kStall,              ///< "stall:N:S": each of N cycles is held S seconds inside the bus (overruns)
};

struct PlannedStep {
  PlannedFault fault = PlannedFault::kDropDrive;
  int cycles = 1;      ///< frames or cycles, 1 … 1000
  double value = 0.0;  ///< push: force [N] > 0; stall: seconds, 0 < S <= 0.1
};

/// Parses a plan of the names above (":N" defaults to 1; push and stall need
/// their value, the others take none). Throws std::invalid_argument naming
/// the step.
std::vector<PlannedStep> parse_planned_faults(const std::string& plan);

class InProcessBus final : public drivers::CanBus, public drivers::BusClock {
 public:
  explicit InProcessBus(SimulatedNodes& nodes);

  /// Time stamped on replies [ns]; the loop sets it to the SYNC time.
  void advance_to(std::int64_t time_ns) noexcept override { time_ns_ = time_ns; }
  Injection& injection() noexcept { return injection_; }

  /// The plan whose steps request_next_step() fires; set before the loop runs.
  void set_plan(std::vector<PlannedStep> plan) { plan_ = std::move(plan); }
  /// Fires the next step of the plan at the next SYNC. Any thread (lock-free);
  /// requests beyond the plan are ignored.
  void request_next_step() noexcept { requested_.fetch_add(1, std::memory_order_relaxed); }
  /// Steps of the plan fired so far.
  int steps_fired() const noexcept { return fired_.load(std::memory_order_relaxed); }

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
  /// At a SYNC: ends a timed step whose cycles are over, fires a requested one.
  void run_plan() noexcept;
  SimulatedNodes* nodes_;
  std::int64_t time_ns_ = 0;
  Injection injection_;
  std::vector<PlannedStep> plan_;
  std::atomic<int> requested_{0};
  std::atomic<int> fired_{0};
  const PlannedStep* timed_ = nullptr;  ///< the bus-off, error-passive, fail-sends, push or stall step under way
  int timed_left_ = 0;                  ///< its cycles still to come, this one included
  static constexpr std::size_t kCapacity = 64;
  std::array<drivers::ReceivedFrame, kCapacity> ring_{};
  std::size_t head_ = 0, tail_ = 0;
  std::array<drivers::ReceivedFrame, 8> delayed_{};
  std::size_t delayed_count_ = 0;
  std::array<can::Frame, 8> monitor_{};
  std::size_t monitor_count_ = 0;
};

}  // namespace clm::sim
