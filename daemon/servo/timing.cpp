#include "daemon/servo/timing.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace clm::servo {

void LatencyHistogram::add(double value_s) noexcept {
  int bin = 0;
  if (value_s > kMin_s) bin = static_cast<int>(std::ceil(kBinsPerDecade * std::log10(value_s / kMin_s)));
  bins_[static_cast<std::size_t>(std::clamp(bin, 0, kBins - 1))] += 1;
  ++count_;
  max_s_ = std::max(max_s_, value_s);
}

void LatencyHistogram::reset() noexcept {
  bins_.fill(0);
  count_ = 0;
  max_s_ = 0.0;
}

double LatencyHistogram::bin_upper_s(int bin) noexcept { return kMin_s * std::pow(10.0, static_cast<double>(bin) / kBinsPerDecade); }

std::array<std::int64_t, LatencyHistogram::kCoarseBins> LatencyHistogram::coarse_counts() const noexcept {
  // Fine bin b holds (kMin_s 10^((b-1)/50), kMin_s 10^(b/50)], so coarse bin
  // j gathers the fine bins with ceil(b / 10) == j.
  constexpr int kFinePerCoarse = kBinsPerDecade / kCoarseBinsPerDecade;
  std::array<std::int64_t, kCoarseBins> coarse{};
  for (int bin = 0; bin < kBins; ++bin) {
    const int j = (bin + kFinePerCoarse - 1) / kFinePerCoarse;
    coarse[static_cast<std::size_t>(j)] += static_cast<std::int64_t>(bins_[static_cast<std::size_t>(bin)]);
  }
  return coarse;
}

double LatencyHistogram::coarse_bin_upper_s(int bin) noexcept {
  if (bin >= kCoarseBins - 1) return std::numeric_limits<double>::infinity();
  return kMin_s * std::pow(10.0, static_cast<double>(bin) / kCoarseBinsPerDecade);
}

double LatencyHistogram::quantile_s(double q) const noexcept {
  if (count_ == 0) return 0.0;
  const auto target = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_)));
  std::uint64_t seen = 0;
  for (int bin = 0; bin < kBins; ++bin) {
    seen += bins_[static_cast<std::size_t>(bin)];
    if (seen >= std::max<std::uint64_t>(target, 1)) return std::min(bin_upper_s(bin), max_s_);
  }
  return max_s_;
}

}  // namespace clm::servo

namespace clm::servo {
namespace {

std::string milliseconds(double value_s) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g ms", value_s * 1e3);
  return text;
}

}  // namespace

std::string TimingMargin::text() const {
  if (watchdog.empty()) return overrun;
  if (overrun.empty()) return watchdog;
  return watchdog + "; " + overrun;
}

double required_watchdog_s(const MeasuredTiming& measured) noexcept {
  return measured.period_s + kWatchdogLatencyFactor * measured.wakeup_latency_max_s;
}

double expected_overrun_trips(const MeasuredTiming& measured, const TimingLimits& limits) noexcept {
  if (measured.cycles <= 0 || measured.overruns <= 0 || !(measured.period_s > 0.0)) return 0.0;
  const double rate = std::min(1.0, static_cast<double>(measured.overruns) / static_cast<double>(measured.cycles));
  const double cycles = limits.duration_s / measured.period_s;
  return cycles * std::pow(rate, std::max(1, limits.overrun_limit));
}

TimingMargin judge_timing_margin(const MeasuredTiming& measured, const TimingLimits& limits) {
  TimingMargin margin;
  char factor[16];
  std::snprintf(factor, sizeof(factor), "%g", kWatchdogLatencyFactor);
  const double required_s = required_watchdog_s(measured);
  if (limits.drive_watchdog_s > 0.0 && limits.drive_watchdog_s < required_s) {
    margin.watchdog = "the drive's setpoint watchdog (drive.watchdog_timeout_s " + milliseconds(limits.drive_watchdog_s) +
                      ") is not comfortably above the loop's measured wake-up latency (max " +
                      milliseconds(measured.wakeup_latency_max_s) + ", p99 " +
                      milliseconds(measured.wakeup_latency_p99_s) + " over " + std::to_string(measured.cycles) +
                      " cycles): a late wake-up lets the watchdog trip the drive (fault 206); it needs at least the "
                      "period + " + factor + " x the max, " + milliseconds(required_s) +
                      ". Fix: reserve a CPU for the loop (loop.cpu with isolcpus=, SCHED_FIFO) to bring the latency "
                      "down, or raise drive.watchdog_timeout_s in the motor file to at least " +
                      milliseconds(required_s);
  }
  const double trips = expected_overrun_trips(measured, limits);
  if (trips >= kOverrunTripsAllowed) {
    char text[480];
    std::snprintf(text, sizeof(text),
                  "faults.overrun_limit %d is likely to latch fault 205: %lld overruns in %lld cycles, so %.3g runs "
                  "of %d in a row are expected in %.0f s (allowed: %g). Fix: reserve a CPU for the loop (loop.cpu "
                  "with isolcpus=, SCHED_FIFO), or raise faults.overrun_limit",
                  limits.overrun_limit, static_cast<long long>(measured.overruns),
                  static_cast<long long>(measured.cycles), trips, limits.overrun_limit, limits.duration_s,
                  kOverrunTripsAllowed);
    margin.overrun = text;
  }
  return margin;
}

}  // namespace clm::servo
