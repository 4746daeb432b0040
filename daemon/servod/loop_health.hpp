#pragma once
// The axis state as other threads may read it: the loop thread stores the
// cycle's state and fault in atomics after every cycle (the ServoCycle's own
// fields are the loop thread's alone) and then hands the cycle on to the
// next observer (the telemetry bridge). Read by the systemd monitor for
// STATUS= and by main at shutdown.

#include <atomic>
#include <cstdio>
#include <string>

#include "daemon/servod/servo_daemon.hpp"

namespace clm::servod {

class LoopHealth final : public CycleObserver {
 public:
  /// `next` (may be null) sees every cycle after this one.
  explicit LoopHealth(CycleObserver* next = nullptr) noexcept : next_(next) {}

  void on_cycle(const servo::ServoCycle& cycle, const LoopTiming& timing) noexcept override {
    state_.store(cycle.status().state, std::memory_order_relaxed);
    fault_.store(cycle.status().fault, std::memory_order_relaxed);
    if (next_ != nullptr) next_->on_cycle(cycle, timing);
  }

  servo::ServoState state() const noexcept { return state_.load(std::memory_order_relaxed); }
  servo::Fault fault() const noexcept { return fault_.load(std::memory_order_relaxed); }

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
};

}  // namespace clm::servod
