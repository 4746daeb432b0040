#pragma once
// clm-servod's core: the configuration made concrete (commutation laws, servo
// cycle) on the bus it is given, the loop on a real-time or virtual clock,
// and the command path. Commands arrive on any non-real-time thread through
// submit(); whatever needs files or planning happens there, and the cycle
// only receives ready objects (Handover) and small commands (SPSC queue).

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "daemon/servo/command.hpp"
#include "daemon/servo/servo_cycle.hpp"
#include "daemon/servo/timing.hpp"
#include "daemon/servod/program_file.hpp"
#include "daemon/servod/servod_config.hpp"
#include "daemon/telemetry/spsc_queue.hpp"
#include "drivers/bus_clock.hpp"
#include "drivers/can_bus.hpp"

namespace clm::servod {

struct CommandReply {
  std::int64_t sequence = 0;
  bool accepted = false;
  std::string text;
  std::int64_t client = 0;  ///< the command's client, for the ack
};

/// Timing of the loop (real-time clock); filled by the loop, read by status.
struct LoopTiming {
  servo::LatencyHistogram wakeup_latency;
  servo::LatencyHistogram compute_time;
  std::int64_t missed_deadlines = 0;   ///< grid points skipped after overruns
  std::int64_t late_setpoints = 0;     ///< setpoints not sent because their cycle was over
};

/// Sees every cycle on the loop thread: must not block or allocate.
class CycleObserver {
 public:
  virtual ~CycleObserver() = default;
  virtual void on_cycle(const servo::ServoCycle& cycle, const LoopTiming& timing) noexcept = 0;
};

/// A commutation law the daemon's builder owns and offers beside the laws of
/// the configuration's files (e.g. the simulator's oracle for
/// CommutationMode::kOracle). `law` must outlive the daemon.
struct ExtraLaw {
  servo::CommutationMode mode = servo::CommutationMode::kOracle;
  const CommutationLaw* law = nullptr;
  std::string source;  ///< what law_source() reports, e.g. "simulator truth"
};

class ServoDaemon {
 public:
  /// Builds the cycle and the laws the configuration names on `bus`, with
  /// `clock` the bus's time base (drivers::no_bus_clock() for real hardware)
  /// and `extra_laws` installed beside them; bus, clock and extra laws must
  /// outlive the daemon (daemon/servod/axis_wiring.hpp builds them from the
  /// configuration). Throws with a precise message (file, key, value) on any
  /// problem.
  ServoDaemon(const ServodConfig& config, drivers::CanBus& bus, drivers::BusClock& clock = drivers::no_bus_clock(),
              std::vector<ExtraLaw> extra_laws = {});
  ~ServoDaemon();
  ServoDaemon(const ServoDaemon&) = delete;
  ServoDaemon& operator=(const ServoDaemon&) = delete;

  /// Non-real-time: checks and completes a command (check_command), then
  /// carries it out as servo::kCommandRoutes says: the kinds the cycle
  /// answers are queued for it and answered in the reply queue once executed
  /// (the reply here is only "queued"); file and planning commands are
  /// answered here.
  CommandReply submit(const servo::Command& command);
  /// Non-real-time: run_program with the program given instead of a file.
  CommandReply submit_program(const ProgramFile& program, std::int64_t sequence = 0);
  /// Replies of queued commands executed by the cycle since the last call.
  std::vector<CommandReply> take_replies();
  /// Frees programs and laws the cycle no longer uses. Non-real-time.
  void collect_garbage();

  /// Virtual clock: runs `cycles` cycles on this thread at full speed.
  void run_cycles(std::int64_t cycles);
  /// Virtual clock: runs until the running program ends (and the axis is
  /// idle), at most `max_cycles`; returns the cycles run.
  std::int64_t run_until_idle(std::int64_t max_cycles);
  /// Real-time clock: runs on the calling thread until `stop` is set.
  void run_realtime(const std::atomic<bool>& stop);

  void set_observer(CycleObserver* observer) noexcept { observer_ = observer; }
  servo::ServoCycle& cycle() noexcept { return *cycle_; }
  const LoopTiming& timing() const noexcept { return timing_; }
  const ServodConfig& config() const noexcept { return config_; }
  /// Cycles completed; the watchdog thread checks it advances.
  std::int64_t cycles_done() const noexcept { return cycles_done_.load(std::memory_order_acquire); }
  std::string law_source(servo::CommutationMode mode) const;
  drivers::BusState bus_state() const noexcept { return bus_->state(); }

 private:
  struct RtReply;
  struct OwnedLaw;
  void one_cycle(std::int64_t sync_time_ns, std::int64_t deadline_ns, double time_s, std::int64_t next_sync_ns,
                 bool realtime) noexcept;
  void drain_commands() noexcept;
  std::unique_ptr<OwnedLaw> build_law(servo::CommutationMode mode, const std::string& path) const;
  /// submit without the client: the reply to `received`.
  CommandReply answer(const servo::Command& received);
  CommandReply queue(const servo::Command& command);
  CommandReply post_program(const servo::Command& command, const ProgramFile* program);

  ServodConfig config_;
  drivers::CanBus* bus_;
  drivers::BusClock* clock_;
  std::vector<ExtraLaw> extra_laws_;
  std::unique_ptr<servo::ServoCycle> cycle_;
  std::vector<std::unique_ptr<OwnedLaw>> laws_;
  std::vector<std::unique_ptr<control::MoveProgram>> programs_;
  std::unique_ptr<telemetry::SpscQueue<servo::Command>> commands_;
  std::unique_ptr<telemetry::SpscQueue<RtReply>> replies_;
  LoopTiming timing_;
  CycleObserver* observer_ = nullptr;
  std::atomic<std::int64_t> cycles_done_{0};
  std::int64_t virtual_time_ns_ = 0;
};

}  // namespace clm::servod
