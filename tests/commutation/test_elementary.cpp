// The elementary functions of commutation/elementary.hpp: each against
// long double (x87, 64-bit mantissa) over dense grids and at its special
// values, and the tanh kernel's two lane widths against each other.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "commutation/elementary.hpp"

using namespace clm;

namespace {

// |computed − exact| in units of the last place of the double nearest to `exact`.
double ulp_error(double computed, long double exact) {
  const double nearest = static_cast<double>(exact);
  if (computed == nearest) return 0.0;
  const double magnitude = std::fabs(nearest);
  const double ulp = std::nextafter(magnitude, std::numeric_limits<double>::infinity()) - magnitude;
  return static_cast<double>(std::fabs(static_cast<long double>(computed) - exact) / ulp);
}

// |computed − reference| / |reference|, and exact equality required where the
// reference is 0 or ±1 (signed zeros, saturation).
double relative_error(double computed, double reference) {
  if (reference == 0.0 || std::fabs(reference) == 1.0) {
    return computed == reference && std::signbit(computed) == std::signbit(reference) ? 0.0 : 1.0;
  }
  return std::fabs(computed - reference) / std::fabs(reference);
}

double max_relative_error(const std::vector<double>& x) {
  std::vector<double> y(x.size());
  elementary::tanh_array(x.data(), y.data(), static_cast<int>(x.size()));
  double worst = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) worst = std::max(worst, relative_error(y[k], std::tanh(x[k])));
  return worst;
}


}  // namespace

TEST_CASE("tanh_array agrees with std::tanh to 1e-13 relative over a dense grid", "[elementary][tanh]") {
  std::vector<double> x;
  // Uniform over the range that matters, through saturation (tanh rounds to ±1 from about 19.1).
  for (int k = -4'000'000; k <= 4'000'000; ++k) x.push_back(k * 6.25e-6);  // ±25, step 6.25e-6
  CHECK(max_relative_error(x) <= 1e-13);
  x.clear();
  // Tiny to large, logarithmically: 2^-1074 (the smallest subnormal) up to 2^10, both signs,
  // 64 points per octave.
  for (int k = -1074 * 64; k <= 10 * 64; ++k) {
    const double v = std::exp2(k / 64.0);
    x.push_back(v);
    x.push_back(-v);
  }
  CHECK(max_relative_error(x) <= 1e-13);
  x.clear();
  // Random doubles near the branch points of the reduction (multiples of ln2/4 in 2|x|).
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jitter(-1e-12, 1e-12);
  for (int n = 0; n < 200; ++n) {
    for (int j = 0; j < 50; ++j) x.push_back((n * 0.25 * M_LN2) * (1.0 + jitter(rng)));
  }
  CHECK(max_relative_error(x) <= 1e-13);
}

TEST_CASE("tanh_array keeps signed zeros and saturates infinities, NaN stays NaN", "[elementary][tanh]") {
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> x = {0.0, -0.0, inf, -inf, 1e300, -1e300, 22.0, -19.5, nan};
  std::vector<double> y(x.size());
  elementary::tanh_array(x.data(), y.data(), static_cast<int>(x.size()));
  CHECK((y[0] == 0.0 && !std::signbit(y[0])));
  CHECK((y[1] == 0.0 && std::signbit(y[1])));
  CHECK(y[2] == 1.0);
  CHECK(y[3] == -1.0);
  CHECK(y[4] == 1.0);
  CHECK(y[5] == -1.0);
  CHECK(y[6] == std::tanh(22.0));
  CHECK(y[7] == std::tanh(-19.5));
  CHECK(std::isnan(y[8]));
}

TEST_CASE("tanh_array handles every length and works in place", "[elementary][tanh]") {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> value(-5.0, 5.0);
  for (int count = 0; count <= 13; ++count) {
    std::vector<double> x(static_cast<std::size_t>(count) + 2, 42.0);  // guards after the end
    for (int k = 0; k < count; ++k) x[static_cast<std::size_t>(k)] = value(rng);
    const std::vector<double> original = x;
    elementary::tanh_array(x.data(), x.data(), count);
    for (int k = 0; k < count; ++k) {
      const auto i = static_cast<std::size_t>(k);
      REQUIRE(relative_error(x[i], std::tanh(original[i])) <= 1e-13);
    }
    REQUIRE(x[static_cast<std::size_t>(count)] == 42.0);
    REQUIRE(x[static_cast<std::size_t>(count) + 1] == 42.0);
  }
}

TEST_CASE("tanh_array gives bit-identical results on the AVX2 and the baseline path", "[elementary][tanh]") {
  INFO("this CPU " << (elementary::detail::tanh_array_uses_avx2() ? "takes" : "does not take") << " the AVX2 path");
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> value(-25.0, 25.0);
  std::vector<double> x(100'003);  // not a multiple of 4 or 8: every tail
  for (auto& v : x) v = value(rng);
  for (int k = 0; k < 64; ++k) x[static_cast<std::size_t>(k)] = std::ldexp(1.0, -k * 16);
  std::vector<double> dispatched(x.size()), baseline(x.size());
  for (int count : {0, 1, 2, 3, 5, 7, 9, 100'003}) {
    elementary::tanh_array(x.data(), dispatched.data(), count);
    elementary::detail::tanh_array_baseline(x.data(), baseline.data(), count);
    for (int k = 0; k < count; ++k) {
      const auto i = static_cast<std::size_t>(k);
      REQUIRE(std::memcmp(&dispatched[i], &baseline[i], sizeof(double)) == 0);
    }
  }
}

TEST_CASE("sin_cos is within 1 ulp of long double over ±2000 rad and tiny angles", "[elementary]") {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> angle(-2000.0, 2000.0), unit(-1.0, 1.0);
  double worst_sin = 0.0, worst_cos = 0.0, at_sin = 0.0, at_cos = 0.0;
  for (int k = 0; k < 400'000; ++k) {
    const double x = k % 4 == 0 ? std::ldexp(unit(rng), -(k % 61)) : angle(rng);
    const auto [s, c] = elementary::sin_cos(x);
    const double es = ulp_error(s, sinl(static_cast<long double>(x)));
    const double ec = ulp_error(c, cosl(static_cast<long double>(x)));
    if (es > worst_sin) worst_sin = es, at_sin = x;
    if (ec > worst_cos) worst_cos = ec, at_cos = x;
  }
  // Near multiples of π/2, where the reduction cancels most.
  for (int n = -1000; n <= 1000; ++n) {
    const double x = n * 1.5707963267948966;
    for (double near : {x, std::nextafter(x, 1e9), std::nextafter(x, -1e9)}) {
      const auto [s, c] = elementary::sin_cos(near);
      const double es = ulp_error(s, sinl(static_cast<long double>(near)));
      const double ec = ulp_error(c, cosl(static_cast<long double>(near)));
      if (es > worst_sin) worst_sin = es, at_sin = near;
      if (ec > worst_cos) worst_cos = ec, at_cos = near;
    }
  }
  INFO("sin: worst " << worst_sin << " ulp at " << at_sin << "; cos: worst " << worst_cos << " ulp at " << at_cos);
  CHECK(worst_sin <= 1.0);
  CHECK(worst_cos <= 1.0);
  CHECK(elementary::sin(0.0) == 0.0);
  CHECK(std::signbit(elementary::sin(-0.0)));
  CHECK(elementary::cos(0.0) == 1.0);
  CHECK(std::isnan(elementary::sin(std::numeric_limits<double>::infinity())));
  CHECK(std::isnan(elementary::cos(std::numeric_limits<double>::quiet_NaN())));
  // Beyond the three-part reduction the C library answers.
  CHECK(elementary::sin(1e7) == std::sin(1e7));
}

TEST_CASE("sin and cos alone give the bits of sin_cos", "[elementary]") {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> angle(-2000.0, 2000.0), unit(-1.0, 1.0);
  const auto same_bits = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  std::vector<double> arguments = {0.0, -0.0, 1e7, -3e9, std::numeric_limits<double>::infinity(),
                                   -std::numeric_limits<double>::infinity()};
  for (int k = 0; k < 200'000; ++k) arguments.push_back(k % 4 == 0 ? std::ldexp(unit(rng), -(k % 61)) : angle(rng));
  for (int n = -1000; n <= 1000; ++n) {
    const double x = n * 1.5707963267948966;
    arguments.insert(arguments.end(), {x, std::nextafter(x, 1e9), std::nextafter(x, -1e9)});
  }
  int differing = 0;
  for (const double x : arguments) {
    const auto [s, c] = elementary::sin_cos(x);
    if (!same_bits(elementary::sin(x), s) || !same_bits(elementary::cos(x), c)) ++differing;
  }
  CHECK(differing == 0);
  CHECK(std::isnan(elementary::sin(std::numeric_limits<double>::quiet_NaN())));
  CHECK(std::isnan(elementary::cos(std::numeric_limits<double>::infinity())));
}

TEST_CASE("exp is within 1 ulp of long double, overflow, underflow and subnormals included", "[elementary]") {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> wide(-745.0, 709.7), narrow(-5.0, 5.0);
  double worst = 0.0, at = 0.0;
  for (int k = 0; k < 400'000; ++k) {
    const double x = k % 2 == 0 ? wide(rng) : narrow(rng);
    const double e = ulp_error(elementary::exp(x), expl(static_cast<long double>(x)));
    if (e > worst) worst = e, at = x;
  }
  INFO("worst " << worst << " ulp at " << at);
  CHECK(worst <= 1.0);
  const double inf = std::numeric_limits<double>::infinity();
  CHECK(elementary::exp(0.0) == 1.0);
  CHECK(elementary::exp(710.0) == inf);
  CHECK(elementary::exp(inf) == inf);
  CHECK(elementary::exp(-inf) == 0.0);
  CHECK(elementary::exp(-746.0) == 0.0);
  CHECK(std::isnan(elementary::exp(std::numeric_limits<double>::quiet_NaN())));
}

TEST_CASE("log is within 1 ulp of long double from subnormals to the largest double", "[elementary]") {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> exponent(-1074.0, 1023.0), near_one(0.5, 2.0);
  double worst = 0.0, at = 0.0;
  for (int k = 0; k < 400'000; ++k) {
    const double x = k % 2 == 0 ? std::exp2(exponent(rng)) : near_one(rng);
    const double e = ulp_error(elementary::log(x), logl(static_cast<long double>(x)));
    if (e > worst) worst = e, at = x;
  }
  INFO("worst " << worst << " ulp at " << at);
  CHECK(worst <= 1.0);
  CHECK(elementary::log(1.0) == 0.0);
  CHECK(elementary::log(0.0) == -std::numeric_limits<double>::infinity());
  CHECK(std::isnan(elementary::log(-1.0)));
  CHECK(elementary::log(std::numeric_limits<double>::infinity()) == std::numeric_limits<double>::infinity());
}

TEST_CASE("atan2 is within 2 ulp of long double in every quadrant, with the C library's special values",
          "[elementary]") {
  std::mt19937_64 rng(19);
  std::uniform_real_distribution<double> value(-10.0, 10.0);
  double worst = 0.0, at_y = 0.0, at_x = 0.0;
  for (int k = 0; k < 400'000; ++k) {
    double y = value(rng), x = value(rng);
    if (k % 3 == 1) y = std::ldexp(y, -(k % 80));
    if (k % 3 == 2) x = std::ldexp(x, -(k % 80));
    const double e = ulp_error(elementary::atan2(y, x), atan2l(static_cast<long double>(y), static_cast<long double>(x)));
    if (e > worst) worst = e, at_y = y, at_x = x;
  }
  INFO("worst " << worst << " ulp at (" << at_y << ", " << at_x << ")");
  CHECK(worst <= 2.0);
  const double inf = std::numeric_limits<double>::infinity();
  for (double y : {0.0, -0.0, 1.0, -1.0, inf, -inf}) {
    for (double x : {0.0, -0.0, 1.0, -1.0, inf, -inf}) {
      INFO("atan2(" << y << ", " << x << ")");
      CHECK(elementary::atan2(y, x) == std::atan2(y, x));
      CHECK(std::signbit(elementary::atan2(y, x)) == std::signbit(std::atan2(y, x)));
    }
  }
}

TEST_CASE("the scalar tanh is the kernel of tanh_array", "[elementary][tanh]") {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> value(-25.0, 25.0);
  for (int k = 0; k < 10'000; ++k) {
    const double x = value(rng);
    double y;
    elementary::tanh_array(&x, &y, 1);
    REQUIRE(elementary::tanh(x) == y);
  }
}
