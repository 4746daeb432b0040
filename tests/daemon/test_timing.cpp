// The cycle's timing histogram: quantiles and the coarse bins of the status
// message, against values placed at known positions.

#include <catch2/catch.hpp>
#include <cmath>
#include <numeric>

#include "daemon/servo/timing.hpp"

using clm::servo::LatencyHistogram;

TEST_CASE("coarse bins hold each value between their edges, and every value once", "[timing]") {
  LatencyHistogram histogram;
  // Values strictly inside a coarse bin j: geometric middle of its edges.
  const auto inside_s = [](int j) { return 1e-7 * std::pow(10.0, (j - 0.5) / 5.0); };
  for (int j = 1; j < LatencyHistogram::kCoarseBins; ++j) {
    for (int n = 0; n < j; ++n) histogram.add(inside_s(j));
  }
  histogram.add(0.0);    // bin 0: up to 100 ns
  histogram.add(5e-8);
  histogram.add(10.0);   // far beyond the last edge: the last bin
  const auto coarse = histogram.coarse_counts();
  REQUIRE(coarse.size() == 31);
  CHECK(coarse[0] == 2);
  for (int j = 1; j + 1 < LatencyHistogram::kCoarseBins; ++j) {
    INFO("bin " << j);
    CHECK(coarse[static_cast<std::size_t>(j)] == j);
    CHECK(inside_s(j) <= LatencyHistogram::coarse_bin_upper_s(j));
    CHECK(inside_s(j) > LatencyHistogram::coarse_bin_upper_s(j - 1));
  }
  CHECK(coarse.back() == 30 + 1);  // bin 30: its 30 values and the one far beyond
  CHECK(std::isinf(LatencyHistogram::coarse_bin_upper_s(LatencyHistogram::kCoarseBins - 1)));
  CHECK(std::accumulate(coarse.begin(), coarse.end(), std::int64_t{0}) == static_cast<std::int64_t>(histogram.count()));
  // Edges: 1 µs is the upper edge of coarse bin 5, and a value just above it is in bin 6.
  LatencyHistogram edges;
  edges.add(1e-6 * 0.999);
  edges.add(1e-6 * 1.001);
  CHECK(edges.coarse_counts()[5] == 1);
  CHECK(edges.coarse_counts()[6] == 1);
}

TEST_CASE("quantiles are read to within one fine bin, and never above the maximum", "[timing]") {
  LatencyHistogram histogram;
  for (int i = 1; i <= 1000; ++i) histogram.add(i * 1e-6);  // 1 µs .. 1 ms, uniform
  const double fine_ratio = std::pow(10.0, 1.0 / LatencyHistogram::kBinsPerDecade);
  for (const double q : {0.1, 0.5, 0.9, 0.99}) {
    INFO("q " << q);
    const double exact_s = q * 1e-3;
    CHECK(histogram.quantile_s(q) >= exact_s * (1 - 1e-12));  // an exact bin edge may round either way
    CHECK(histogram.quantile_s(q) <= exact_s * fine_ratio * (1 + 1e-12));
  }
  CHECK(histogram.quantile_s(1.0) == histogram.max_s());
  CHECK(histogram.max_s() == 1e-3);
  histogram.reset();
  CHECK(histogram.quantile_s(0.5) == 0.0);
  CHECK(histogram.coarse_counts()[0] == 0);
}
