#pragma once
// Fixed-bin latency histogram for the cycle: log-spaced bins from 100 ns to
// 100 ms (50 per decade, so a percentile is read to within 5 %), no
// allocation, percentiles read from the bins, and a coarse copy (5 bins per
// decade) for the status message.

#include <array>
#include <cstdint>

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
