#include "daemon/servo/timing.hpp"

#include <algorithm>
#include <cmath>

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
