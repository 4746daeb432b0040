#include "daemon/servo/timing.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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
