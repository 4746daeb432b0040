#pragma once
// Fixed-bin latency histogram for the cycle: log-spaced bins from 100 ns to
// 100 ms (50 per decade, so a percentile is read to within 5 %), no
// allocation, percentiles read from the bins, and a coarse copy (5 bins per
// decade) for the status message. And the timing margin: whether the
// measured wake-up latency and overruns make the drive's setpoint watchdog or
// faults.overrun_limit likely to trip (one rule, for the daemon's start-up
// warning and `clm commission --live`'s refusal).

#include <array>
#include <cstdint>
#include <string>

namespace clm::servo {

class LatencyHistogram {
 public:
  static constexpr int kBinsPerDecade = 50;
  static constexpr int kBins = 6 * kBinsPerDecade;
  static constexpr double kMin_s = 1e-7;

  void add(double value_s) noexcept;
  void reset() noexcept;
  std::uint64_t count() const noexcept { return count_; }
  double max_s() const noexcept { return max_s_; }
  /// Upper edge of the bin holding quantile q in [0, 1]; 0 when empty.
  double quantile_s(double q) const noexcept;
  /// Upper edge of bin `bin` [s].
  static double bin_upper_s(int bin) noexcept;

  static constexpr int kCoarseBinsPerDecade = 5;
  static constexpr int kCoarseBins = kBins / (kBinsPerDecade / kCoarseBinsPerDecade) + 1;
  /// The counts in coarse bins: bin j counts the values in
  /// (kMin_s 10^((j-1)/5), kMin_s 10^(j/5)] s; bin 0 every value up to
  /// kMin_s, the last bin every value beyond the one before it.
  std::array<std::int64_t, kCoarseBins> coarse_counts() const noexcept;
  /// Upper edge of coarse bin `bin` [s] (the last bin has none: infinity).
  static double coarse_bin_upper_s(int bin) noexcept;

 private:
  std::array<std::uint64_t, kBins> bins_{};
  std::uint64_t count_ = 0;
  double max_s_ = 0.0;
};

}  // namespace clm::servo

// ---- the timing margin: one rule for the daemon's start-up warning and
// `clm commission --live`'s refusal (docs/servod.md, "Timing margins") ----

namespace clm::servo {

/// The loop's timing as the status reports it (cumulative since the start).
struct MeasuredTiming {
  double period_s = 0.0;              ///< the cycle's period [s], > 0
  double wakeup_latency_p99_s = 0.0;  ///< [s]
  double wakeup_latency_max_s = 0.0;  ///< [s]
  std::int64_t cycles = 0;            ///< cycles measured
  std::int64_t overruns = 0;          ///< of those, cycles after an overrun
};

/// The settings that trip on late wake-ups, and how long they must hold.
struct TimingLimits {
  /// The drive's setpoint watchdog, drive.watchdog_timeout_s of the motor
  /// file [s]; 0: the file does not say, and the watchdog is not judged.
  double drive_watchdog_s = 0.0;
  int overrun_limit = 5;       ///< faults.overrun_limit: consecutive overruns that latch fault 205
  double duration_s = 3600.0;  ///< how long the axis is to run without a trip [s]
};

/// The watchdog must be at least period + kWatchdogLatencyFactor × the
/// measured maximum wake-up latency: a setpoint can follow the last one by
/// the period plus one wake-up's lateness, and a maximum seen over seconds
/// or minutes is exceeded over hours (the tail of a loaded host's latency
/// reaches several times its early maximum; docs/design-decisions.md).
inline constexpr double kWatchdogLatencyFactor = 3.0;
/// The overrun limit is at risk when the expected number of runs of
/// overrun_limit consecutive overruns over the duration, at the observed
/// overrun rate p taken as independent per cycle (cycles · p^limit), reaches this.
inline constexpr double kOverrunTripsAllowed = 0.01;

/// The verdict: each part empty when that limit has margin, else one
/// sentence with the measured figures, the limit, what trips, and the fix.
struct TimingMargin {
  std::string watchdog;
  std::string overrun;
  bool at_risk() const { return !watchdog.empty() || !overrun.empty(); }
  /// The non-empty parts joined by "; ".
  std::string text() const;
};

/// The smallest drive watchdog with margin for `measured` [s]:
/// period_s + kWatchdogLatencyFactor × wakeup_latency_max_s.
double required_watchdog_s(const MeasuredTiming& measured) noexcept;

/// Expected runs of `limits.overrun_limit` consecutive overruns over
/// limits.duration_s at the measured overrun rate (0 without overruns).
double expected_overrun_trips(const MeasuredTiming& measured, const TimingLimits& limits) noexcept;

/// Judges `limits` against `measured` by the two rules above. Pure: no I/O.
TimingMargin judge_timing_margin(const MeasuredTiming& measured, const TimingLimits& limits);

}  // namespace clm::servo
