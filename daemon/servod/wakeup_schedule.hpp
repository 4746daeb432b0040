#pragma once
// The loop's sleep policy, apart from the clock so it can be tested: absolute
// wake-up times on a fixed period grid. After an overrun the schedule skips
// the periods already missed (counted) instead of bursting to catch up, so
// no cycle ever runs on a stale SYNC slot.

#include <cstdint>

namespace clm::servod {

class WakeupSchedule {
 public:
  WakeupSchedule(std::int64_t start_ns, std::int64_t period_ns) : next_ns_(start_ns), period_ns_(period_ns) {}

  /// The absolute time of the next wake-up [ns].
  std::int64_t next_ns() const noexcept { return next_ns_; }
  std::int64_t period_ns() const noexcept { return period_ns_; }

  /// Called when a cycle's work ends at `now_ns`: moves the wake-up to the
  /// next grid point after now and returns how many grid points were missed
  /// (0 when the cycle ended within its period).
  std::int64_t advance(std::int64_t now_ns) noexcept {
    next_ns_ += period_ns_;
    if (now_ns < next_ns_) return 0;
    const std::int64_t missed = (now_ns - next_ns_) / period_ns_ + 1;
    next_ns_ += missed * period_ns_;
    return missed;
  }

 private:
  std::int64_t next_ns_;
  std::int64_t period_ns_;
};

}  // namespace clm::servod
