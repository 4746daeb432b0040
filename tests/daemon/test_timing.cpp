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

// ---- the timing margin (daemon/servo/timing.hpp), against figures worked by hand ----

using clm::servo::judge_timing_margin;
using clm::servo::MeasuredTiming;
using clm::servo::TimingLimits;

TEST_CASE("a watchdog below period + 3 x the max wake-up latency is at risk, naming both and the fix", "[timing]") {
  // 1 ms period, 2 ms max latency: at least 1 + 3 * 2 = 7 ms is needed.
  const MeasuredTiming measured{1e-3, 0.4e-3, 2e-3, 1000, 0};
  const auto short_watchdog = judge_timing_margin(measured, {5e-3, 5, 3600.0});
  CHECK(short_watchdog.at_risk());
  CHECK(short_watchdog.overrun.empty());
  CHECK_THAT(short_watchdog.watchdog, Catch::Contains("drive.watchdog_timeout_s 5 ms"));
  CHECK_THAT(short_watchdog.watchdog, Catch::Contains("max 2 ms"));
  CHECK_THAT(short_watchdog.watchdog, Catch::Contains("at least 7 ms"));
  CHECK_THAT(short_watchdog.watchdog, Catch::Contains("Fix:"));
  CHECK(clm::servo::required_watchdog_s(measured) == Approx(7e-3));
  CHECK_FALSE(judge_timing_margin(measured, {7.01e-3, 5, 3600.0}).at_risk());
  // A motor file that does not state its watchdog is not judged on it.
  CHECK_FALSE(judge_timing_margin(measured, {0.0, 5, 3600.0}).at_risk());
}

TEST_CASE("an overrun limit is at risk when cycles x rate^limit reaches 1 %", "[timing]") {
  // 10 overruns in 10000 cycles: rate 1e-3. One hour at 1 kHz = 3.6e6 cycles.
  const MeasuredTiming measured{1e-3, 0.1e-3, 0.5e-3, 10000, 10};
  // limit 2: 3.6e6 * 1e-6 = 3.6 expected trips; limit 3: 3.6e-3, below 0.01.
  CHECK(clm::servo::expected_overrun_trips(measured, {0.0, 2, 3600.0}) == Approx(3.6));
  const auto two = judge_timing_margin(measured, {0.0, 2, 3600.0});
  CHECK(two.watchdog.empty());
  CHECK_THAT(two.overrun, Catch::Contains("faults.overrun_limit 2"));
  CHECK_THAT(two.overrun, Catch::Contains("10 overruns in 10000 cycles"));
  CHECK_THAT(two.overrun, Catch::Contains("raise faults.overrun_limit"));
  CHECK_FALSE(judge_timing_margin(measured, {0.0, 3, 3600.0}).at_risk());
  // No overrun seen: no risk at any limit.
  CHECK_FALSE(judge_timing_margin({1e-3, 0.1e-3, 0.5e-3, 10000, 0}, {0.0, 1, 3600.0}).at_risk());
  // Both parts at once, joined.
  const auto both = judge_timing_margin({1e-3, 0.4e-3, 2e-3, 10000, 10}, {5e-3, 2, 3600.0});
  CHECK(both.text() == both.watchdog + "; " + both.overrun);
}
