#pragma once
// The axis state as other threads may read it: the loop thread stores the
// cycle's state and fault in atomics after every cycle (the ServoCycle's own
// fields are the loop thread's alone), counts fault latches, and then hands
// the cycle on to the next observer (the telemetry bridge). Read by the
// systemd monitor for STATUS= and the journal's fault lines, and by main at
// shutdown; and the loop's measured timing, which the monitor judges once
// after the first second (take_timing_warning).

#include <atomic>
#include <cstdio>
#include <string>

#include "daemon/servo/timing.hpp"
#include "daemon/servod/servo_daemon.hpp"

namespace clm::servod {

class LoopHealth final : public CycleObserver {
 public:
  /// `next` (may be null) sees every cycle after this one.
  explicit LoopHealth(CycleObserver* next = nullptr) noexcept : next_(next) {}

  void on_cycle(const servo::ServoCycle& cycle, const LoopTiming& timing) noexcept override {
    const servo::Fault fault = cycle.status().fault;
    state_.store(cycle.status().state, std::memory_order_relaxed);
    if (fault != servo::Fault::kNone && fault != fault_.load(std::memory_order_relaxed)) {
      fault_cycle_.store(cycle.status().fault_cycle, std::memory_order_relaxed);
      latches_.fetch_add(1, std::memory_order_release);
    }
    fault_.store(fault, std::memory_order_relaxed);
    // The timing the start-up warning judges; the p99 (a scan of the bins)
    // every kQuantileEvery cycles.
    const auto& counters = cycle.status().counters;
    latency_max_s_.store(timing.wakeup_latency.max_s(), std::memory_order_relaxed);
    if (counters.cycles % kQuantileEvery == 0) {
      latency_p99_s_.store(timing.wakeup_latency.quantile_s(0.99), std::memory_order_relaxed);
    }
    overruns_.store(counters.overruns, std::memory_order_relaxed);
    cycles_.store(counters.cycles, std::memory_order_release);
    if (next_ != nullptr) next_->on_cycle(cycle, timing);
  }

  servo::ServoState state() const noexcept { return state_.load(std::memory_order_relaxed); }
  servo::Fault fault() const noexcept { return fault_.load(std::memory_order_relaxed); }

  /// One line for the journal per fault latched since the last call, from
  /// any non-real-time thread: "fault 203 latched in cycle 1234 (1.234 s
  /// after the start): <reason>", with `period_s` the cycle's period;
  /// latches between two calls that are no longer the latched fault are
  /// counted in it ("and 2 earlier latches since the last report"). Empty
  /// when none latched.
  std::string take_fault_report(double period_s) {
    const std::int64_t latches = latches_.load(std::memory_order_acquire);
    if (latches == reported_) return "";
    const std::int64_t missed = latches - reported_ - 1;
    reported_ = latches;
    const servo::Fault fault = this->fault();
    const std::int64_t cycle = fault_cycle_.load(std::memory_order_relaxed);
    char text[256];
    std::snprintf(text, sizeof(text), "fault %d latched in cycle %lld (%.3f s after the start): %s%s",
                  static_cast<int>(fault), static_cast<long long>(cycle), static_cast<double>(cycle) * period_s,
                  servo::describe(fault),
                  missed > 0 ? (", and " + std::to_string(missed) + " earlier latches since the last report").c_str()
                             : "");
    return text;
  }

  /// Once, when the loop has run `after_s` [s] of cycles of `period_s` [s]
  /// (a wake-up latency measured over them): "timing margin: ..." when
  /// servo::judge_timing_margin finds `limits` at risk, with the figures and
  /// the fix; else, and on every later call, "". Non-real-time.
  std::string take_timing_warning(double period_s, const servo::TimingLimits& limits, double after_s = 1.0) {
    if (timing_judged_) return "";
    const std::int64_t cycles = cycles_.load(std::memory_order_acquire);
    if (static_cast<double>(cycles) * period_s < after_s) return "";
    timing_judged_ = true;
    const servo::MeasuredTiming measured{period_s, latency_p99_s_.load(std::memory_order_relaxed),
                                         latency_max_s_.load(std::memory_order_relaxed), cycles,
                                         overruns_.load(std::memory_order_relaxed)};
    const servo::TimingMargin margin = servo::judge_timing_margin(measured, limits);
    return margin.at_risk() ? "timing margin: " + margin.text() : "";
  }

  /// "state enabled, fault 0 (none)": the STATUS= line. Non-real-time.
  std::string status_line() const {
    const servo::Fault fault = this->fault();
    char text[160];
    std::snprintf(text, sizeof(text), "state %s, fault %d (%s)", servo::name(state()), static_cast<int>(fault),
                  servo::describe(fault));
    return text;
  }

 private:
  CycleObserver* next_;
  std::atomic<servo::ServoState> state_{servo::ServoState::kDisabled};
  std::atomic<servo::Fault> fault_{servo::Fault::kNone};
  std::atomic<std::int64_t> fault_cycle_{-1};
  std::atomic<std::int64_t> latches_{0};
  std::int64_t reported_ = 0;  // take_fault_report's thread
  static constexpr std::int64_t kQuantileEvery = 100;
  std::atomic<double> latency_max_s_{0.0};
  std::atomic<double> latency_p99_s_{0.0};
  std::atomic<std::int64_t> overruns_{0};
  std::atomic<std::int64_t> cycles_{0};
  bool timing_judged_ = false;  // take_timing_warning's thread
};

}  // namespace clm::servod
