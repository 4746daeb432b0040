#pragma once
// clm-servod's core: the configuration made concrete (commutation laws, servo
// cycle) on the bus it is given, the loop on a real-time or virtual clock,
// the laws and their files, and the routing of each command to what answers
// it. Commands arrive on any non-real-time thread through submit(); moves are
// decided and offered there (MoveOffers), run-time parameters kept there
// (ParameterStore), files read on the loader thread when one is set (else
// there too); the cycle only receives ready objects (its CycleMailbox) and
// small commands (SPSC queue).

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <array>
#include <string>
#include <vector>

#include "daemon/servo/command.hpp"
#include "daemon/servod/command_reply.hpp"
#include "daemon/servo/move_decision.hpp"
#include "daemon/servo/servo_cycle.hpp"
#include "daemon/servo/timing.hpp"
#include "daemon/servod/file_loader.hpp"
#include "daemon/servod/file_policy.hpp"
#include "daemon/servod/move_offers.hpp"
#include "daemon/servod/parameter_store.hpp"
#include "daemon/servod/parameters.hpp"
#include "daemon/servod/program_file.hpp"
#include "daemon/servod/servod_config.hpp"
#include "daemon/telemetry/messages.hpp"
#include "daemon/telemetry/spsc_queue.hpp"
#include "drivers/bus_clock.hpp"
#include "drivers/can_bus.hpp"

namespace clm::servod {

/// The files the status names (servo_status_t.*_file, *_sha256).
enum class LoadedFileSlot : std::uint8_t { kCalibration = 0, kPgnnModel, kSplineModel, kFeedforward };
inline constexpr std::size_t kLoadedFileSlots = 4;

/// A deferred law request the cycle replaced by a later one before it took
/// effect (an event names both).
struct Superseded {
  std::int64_t count = 0;       ///< how many so far; changes with each
  std::int64_t superseded = 0;  ///< sequence of the request replaced
  std::int64_t by = 0;          ///< sequence of the request that replaced it
};

/// Timing of the loop (real-time clock); filled by the loop, read by status.
struct LoopTiming {
  servo::LatencyHistogram wakeup_latency;
  servo::LatencyHistogram compute_time;
  std::int64_t missed_deadlines = 0;   ///< grid points skipped after overruns
  std::int64_t late_setpoints = 0;     ///< setpoints not sent because their cycle was over
  std::int64_t longest_compute_cycle = -1;  ///< the cycle (servo_state_t.cycle) with the longest compute time
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

  /// Non-real-time: refuses a command the table (servo::check_legal) does
  /// not allow in the present state, checks and completes it
  /// (check_command), then carries it out as servo::kCommandRoutes says: the
  /// kinds the cycle answers are queued for it and answered in the reply
  /// queue once executed (the reply here is kQueued); a move, program or jog
  /// is decided here (servo::decide_move) and answered by the cycle once it
  /// has taken the program or said why not; the other kinds are answered here.
  /// Files named by a command are read only through check_loadable
  /// (commands.file_directories, commands.max_file_bytes); a file that does
  /// not parse is refused naming its path, line and key, never its content
  /// (the full parser message goes to the log). With a file loader set, files
  /// are read on its thread and the reply is kLoading (answered later); otherwise
  /// on the caller's thread.
  CommandReply submit(const servo::Command& command);
  /// Non-real-time: run_program with the program given instead of a file.
  CommandReply submit_program(const ProgramFile& program, std::int64_t sequence = 0);
  /// Replies of queued commands executed by the cycle since the last call,
  /// and of a load the loader finished (its law or program is posted here).
  std::vector<CommandReply> take_replies();
  /// Loads run on `loader` from now on (nullptr: on the caller's thread). The
  /// loader must outlive the daemon or be unset first.
  void set_file_loader(FileLoader* loader) noexcept { loader_ = loader; }
  /// Where parser messages of refused files go (default: stderr). Called on
  /// the loader thread or the caller's.
  void set_log(std::function<void(const std::string&)> log) { log_ = std::move(log); }
  /// Any thread, async-signal-safe: the loop disables the axis at its next
  /// cycle and keeps it disabled (shutdown).
  void request_disable() noexcept { disable_requested_.store(true, std::memory_order_release); }
  /// Any thread, lock-free, no allocation: latches a stop, quick stop or
  /// disable (servo::is_safety_command) for the next cycle, which obeys it
  /// before anything queued. A flag per kind, not a queue entry: requests
  /// that arrive within one cycle are obeyed together, and nothing else
  /// (commands, files, a full queue) can keep them out. Returns a ticket
  /// (> 0); safety_obeyed() reaches it once a cycle has obeyed the request.
  std::uint64_t request_safety(servo::CommandKind kind) noexcept;
  /// Any thread, lock-free, no allocation: the holder of a deadman lease is
  /// gone (CommandGate::take_lapsed_deadman). Latched as request_safety: the
  /// next cycle quick-stops a running program and ends an experiment (the
  /// service law at standstill). Returns a ticket as request_safety.
  std::uint64_t request_owner_gone() noexcept;
  /// Any thread: the highest ticket a cycle has obeyed.
  std::uint64_t safety_obeyed() const noexcept { return safety_obeyed_.load(std::memory_order_acquire); }
  /// After request_disable: the cycles completed before the cycle that
  /// disabled the axis, and when that cycle did [ns, CLOCK_MONOTONIC];
  /// -1 and 0 until then.
  std::int64_t disabled_after_cycles() const noexcept { return disabled_after_cycles_.load(std::memory_order_acquire); }
  std::int64_t disabled_at_ns() const noexcept { return disabled_at_ns_.load(std::memory_order_acquire); }
  /// Any thread, lock-free (a seqlock read word by word through atomics):
  /// copies the file now in use for `slot` (empty when none) and returns its
  /// generation, which changes with every new file; when the slot was being
  /// rewritten on each of 8 looks, the path "(changing)" and 0.
  std::uint64_t loaded_file(LoadedFileSlot slot, telemetry::LoadedFileText& out) const noexcept;
  /// Any thread: the generation of `slot` alone (odd while it is rewritten),
  /// for a reader that copies the text only when it changed.
  std::uint64_t loaded_file_generation(LoadedFileSlot slot) const noexcept {
    return files_[static_cast<std::size_t>(slot)].generation.load(std::memory_order_acquire);
  }
  /// Commands the daemon refused (by submit, the cycle or the loader).
  std::int64_t commands_refused() const noexcept { return refused_.load(std::memory_order_relaxed); }
  /// Command thread: the run-time parameters the cycle uses now (parameters.hpp).
  RuntimeValues runtime_values() const { return parameters_->values(); }
  /// Loop thread (observers): the last deferred law request superseded.
  const Superseded& superseded() const noexcept { return superseded_; }
  /// Frees programs and laws the cycle no longer uses. Non-real-time.
  void collect_garbage();

  /// Virtual clock: runs `cycles` cycles on this thread at full speed.
  void run_cycles(std::int64_t cycles);
  /// Virtual clock: one cycle started as the real-time loop starts one after
  /// a wake-up gap of `wakeup_gap_s` or an overrun (the virtual loop has
  /// neither of its own).
  void run_cycle_after(double wakeup_gap_s, bool previous_overran);
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
  /// The cycle's answer, fixed size for its reply queue.
  struct RtReply {
    std::int64_t sequence = 0;
    std::int64_t client = 0;
    servo::CommandResult result = servo::CommandResult::kAccepted;
    std::int64_t offer = 0;  ///< a move's: the offer the cycle must decide first (loop thread)
  };
  struct OwnedLaw;
  struct Loaded;
  /// A LoadedFileText as the seqlock's payload: atomic 8-byte words, so that
  /// a read racing a write is a race on atomics (relaxed), not UB; the
  /// generation says whether a copy is whole.
  static constexpr std::size_t kLoadedFileWords =
      (sizeof(telemetry::LoadedFileText) + sizeof(std::uint64_t) - 1) / sizeof(std::uint64_t);
  struct FileSlot {
    std::atomic<std::uint64_t> generation{0};  // odd while written
    std::array<std::atomic<std::uint64_t>, kLoadedFileWords> words{};  // all zero: the empty text
  };
  /// Any thread: reads the file `command` names and builds what it holds.
  std::unique_ptr<Loaded> load(const servo::Command& command) const;
  /// Command thread: posts what `loaded` holds; the reply.
  CommandReply finish_load(Loaded& loaded);
  void set_loaded_file(LoadedFileSlot slot, const std::string& path, const std::string& sha256) noexcept;
  /// Command thread: the status's law files follow the laws the cycle uses.
  void update_law_files() noexcept;
  void mirror_state() noexcept;
  void one_cycle(const servo::CycleStart& start, std::int64_t deadline_ns, double time_s, std::int64_t next_sync_ns,
                 bool realtime) noexcept;
  void drain_commands() noexcept;
  std::unique_ptr<OwnedLaw> build_law(servo::CommutationMode mode, const std::string& path, const std::string& text,
                                      const std::string& sha256) const;
  /// submit without the client: the reply to `received`.
  CommandReply answer(const servo::Command& received);
  CommandReply queue(const servo::Command& command);
  /// A move_to, run_program (`program`) or jog: decided and offered
  /// (MoveOffers) against the state the cycle reports and the parameters in
  /// use, and answered by the cycle.
  CommandReply post_move(const servo::Command& command, const servo::ProgramSteps& program = {});
  /// Loop thread: answers the move whose offer the cycle has decided.
  void answer_offer() noexcept;

  ServodConfig config_;
  drivers::CanBus* bus_;
  drivers::BusClock* clock_;
  std::vector<ExtraLaw> extra_laws_;
  std::unique_ptr<servo::ServoCycle> cycle_;
  std::vector<std::unique_ptr<OwnedLaw>> laws_;
  std::unique_ptr<telemetry::SpscQueue<servo::Command>> commands_;
  std::unique_ptr<telemetry::SpscQueue<RtReply>> replies_;
  std::unique_ptr<ParameterStore> parameters_;
  std::unique_ptr<MoveOffers> moves_;
  LoopTiming timing_;
  CycleObserver* observer_ = nullptr;
  std::atomic<std::int64_t> cycles_done_{0};
  std::int64_t virtual_time_ns_ = 0;

  FilePolicy file_policy_;
  FileLoader* loader_ = nullptr;
  std::function<void(const std::string&)> log_;
  std::mutex loaded_mutex_;             // guards loaded_ (loader thread → command thread)
  std::unique_ptr<Loaded> loaded_;      // a finished load not yet posted
  std::array<FileSlot, kLoadedFileSlots> files_{};
  std::atomic<bool> disable_requested_{false};
  std::atomic<std::int64_t> disabled_after_cycles_{-1};
  std::atomic<std::int64_t> disabled_at_ns_{0};
  void honour_disable_request() noexcept;
  /// Loop thread: obeys the latched stop, quick stop and disable (request_safety).
  void obey_safety_requests() noexcept;
  /// Sets `bit` of safety_requests_ and hands out a ticket.
  std::uint64_t latch_request(std::uint8_t bit) noexcept;
  std::atomic<std::uint8_t> safety_requests_{0};    // one bit per safety kind
  std::atomic<std::uint64_t> safety_requested_{0};  // tickets handed out
  std::atomic<std::uint64_t> safety_obeyed_{0};     // tickets obeyed
  std::atomic<servo::ServoState> state_seen_{servo::ServoState::kDisabled};  // the cycle's, after each command and cycle
  std::atomic<std::int64_t> refused_{0};
  RtReply awaiting_offer_;  // loop thread: the move whose offer the cycle has yet to decide (offer 0: none)
  std::int64_t deferred_sequence_ = 0;  // loop thread: the deferred law request waiting for standstill
  Superseded superseded_;               // loop thread
};

}  // namespace clm::servod
