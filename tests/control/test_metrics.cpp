// The Table 2 filter (docs/commutation.md §11) and the mean-square metrics, against
// closed-form expectations.
#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include "daemon/control/metrics.hpp"
#include "support/allocation_counter.hpp"

using namespace clm::control;
using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

namespace {
constexpr double kPi = std::numbers::pi;
}

TEST_CASE("commutation error filter: step response is 1 - a^k with a = exp(-2 pi 50 T)", "[metrics][filter]") {
  const double period_s = 1e-4;
  const double a = std::exp(-2 * kPi * 50.0 * period_s);
  CommutationErrorFilter filter(50.0, period_s);
  CHECK_THAT(filter.pole(), WithinRel(a, 1e-15));
  for (int k = 0; k < 2000; ++k) {
    REQUIRE_THAT(filter.update(1.0), WithinAbs(1.0 - std::pow(a, k), 1e-12));
  }
  filter.reset();
  CHECK(filter.update(3.0) == 0.0);  // one-sample delay from a zero state
  CHECK_THAT(filter.update(3.0), WithinAbs(3.0 * (1 - a), 1e-15));
}

TEST_CASE("commutation error filter: sine gain equals |(1-a) z^-1 / (1 - a z^-1)|", "[metrics][filter]") {
  const double period_s = 1e-3, cutoff_hz = 50.0;
  const double a = std::exp(-2 * kPi * cutoff_hz * period_s);
  for (const double frequency_hz : {5.0, 50.0, 200.0}) {
    CommutationErrorFilter filter(cutoff_hz, period_s);
    const double w = 2 * kPi * frequency_hz;
    const std::complex<double> z_inv = std::exp(std::complex<double>(0.0, -w * period_s));
    const double gain = std::abs((1 - a) * z_inv / (1.0 - a * z_inv));
    double peak = 0.0;
    for (int k = 0; k < 4000; ++k) {
      const double y = filter.update(std::sin(w * k * period_s));
      if (k >= 2000) peak = std::max(peak, std::abs(y));
    }
    // The largest sample of a sampled sine lies within half a sample of the crest, so it is at least
    // cos(π·f·T_s) of the crest.
    CHECK(peak <= gain * (1 + 1e-9));
    CHECK(peak >= gain * std::cos(kPi * frequency_hz * period_s) * (1 - 1e-9));
  }
  REQUIRE_THROWS_WITH(CommutationErrorFilter(0.0, 1e-3), Contains("cutoff_hz"));
  REQUIRE_THROWS_WITH(CommutationErrorFilter(50.0, -1e-3), Contains("period_s"));
}

TEST_CASE("commutation_error_mse of a constant error: c^2 unfiltered, closed form filtered", "[metrics][mse]") {
  const double period_s = 2e-4;
  const std::size_t n = 5000;
  const Eigen::Vector3d offset(1.5, -0.2, 0.03);
  std::vector<Eigen::Vector3d> desired(n), measured(n);
  for (std::size_t k = 0; k < n; ++k) {
    desired[k] = Eigen::Vector3d(std::sin(0.01 * k), 0.5, -0.1 * k);
    measured[k] = desired[k] + offset;
  }
  const DirectionMse mse = commutation_error_mse(measured, desired, period_s);
  const double a = std::exp(-2 * kPi * 50.0 * period_s);
  // Σ_{k<n} (1 − a^k)² = n − 2(1 − aⁿ)/(1 − a) + (1 − a²ⁿ)/(1 − a²)
  const double sum = n - 2 * (1 - std::pow(a, n)) / (1 - a) + (1 - std::pow(a, 2 * n)) / (1 - a * a);
  for (int d = 0; d < 3; ++d) {
    const auto i = static_cast<std::size_t>(d);
    CHECK_THAT(mse.unfiltered[i], WithinRel(offset(d) * offset(d), 1e-9));
    CHECK_THAT(mse.filtered[i], WithinRel(offset(d) * offset(d) * sum / n, 1e-9));
  }
}

TEST_CASE("commutation_error_mse of a sine: A^2/2 unfiltered, filter gain squared filtered", "[metrics][mse]") {
  const double period_s = 1e-4, frequency_hz = 100.0;
  const std::size_t n = 200000;  // 200 whole periods
  std::vector<Eigen::Vector3d> desired(n, Eigen::Vector3d::Zero()), measured(n);
  const double w = 2 * kPi * frequency_hz;
  for (std::size_t k = 0; k < n; ++k) {
    const double s = std::sin(w * static_cast<double>(k) * period_s);
    measured[k] = Eigen::Vector3d(2.0 * s, 0.3 * s, 0.05 * s);
  }
  const DirectionMse mse = commutation_error_mse(measured, desired, period_s);
  const double a = std::exp(-2 * kPi * 50.0 * period_s);
  const std::complex<double> z_inv = std::exp(std::complex<double>(0.0, -w * period_s));
  const double gain = std::abs((1 - a) * z_inv / (1.0 - a * z_inv));
  const double amplitude[3] = {2.0, 0.3, 0.05};
  for (std::size_t i = 0; i < 3; ++i) {
    CHECK_THAT(mse.unfiltered[i], WithinRel(amplitude[i] * amplitude[i] / 2, 1e-9));
    // The start-up transient is a few ms of 20 s: within 0.1 %.
    CHECK_THAT(mse.filtered[i], WithinRel(amplitude[i] * amplitude[i] / 2 * gain * gain, 1e-3));
  }
}

TEST_CASE("commutation_error_mse and mean_square reject empty or mismatched records", "[metrics][mse]") {
  std::vector<Eigen::Vector3d> three(3, Eigen::Vector3d::Ones()), two(2, Eigen::Vector3d::Ones());
  REQUIRE_THROWS_WITH(commutation_error_mse(three, two, 1e-3), Contains("3") && Contains("2"));
  REQUIRE_THROWS_WITH(commutation_error_mse({}, {}, 1e-3), Contains("no samples"));
  REQUIRE_THROWS_WITH(commutation_error_mse(three, three, 0.0), Contains("period_s"));
  REQUIRE_THROWS_WITH(mean_square({}), Contains("empty"));
}

TEST_CASE("mean_square of known signals", "[metrics]") {
  const std::vector<double> values{1.0, -2.0, 3.0, -4.0};
  CHECK_THAT(mean_square(values), WithinRel(7.5, 1e-15));
  const std::vector<double> constant(1000, -0.25);
  CHECK_THAT(mean_square(constant), WithinRel(0.0625, 1e-12));
}

TEST_CASE("the commutation error filter does not allocate", "[metrics][allocation]") {
  CommutationErrorFilter filter(50.0, 1e-4);
  double sum = 0.0;
  clm::test::AllocationScope scope;
  for (int k = 0; k < 100000; ++k) sum += filter.update(std::sin(0.001 * k));
  REQUIRE(scope.allocations() == 0);
  REQUIRE(std::isfinite(sum));
}
