// The vectorised tanh of the networks against std::tanh, and both network
// evaluations (per network and fused) against the model written out with
// std::tanh.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include "commutation/model.hpp"
#include "support/random_model.hpp"

using namespace clm;

namespace {

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
  tanh_array(x.data(), y.data(), static_cast<int>(x.size()));
  double worst = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) worst = std::max(worst, relative_error(y[k], std::tanh(x[k])));
  return worst;
}

// The model of eq. (24)/(35) evaluated directly from its parameters with std::tanh.
void reference_evaluate(const ElectromagneticModel& model, double y, StackedGain& gain, Wrench& cogging) {
  const auto network = [&](const Network& net) {
    const double input = (y - model.normalisation.offset_m) / model.normalisation.scale_m;
    Eigen::Vector3d out = net.layers[1].biases;
    for (Eigen::Index n = 0; n < net.layers[0].biases.size(); ++n) {
      out += net.layers[1].weights.col(n) * std::tanh(net.layers[0].weights(n, 0) * input + net.layers[0].biases[n]);
    }
    return out;
  };
  const double theta = 2.0 * M_PI * y / model.pole_pitch_m;
  const int count = model.coil_set_count();
  gain.resize(3, 2 * count);
  cogging.setZero();
  for (int l = 0; l < count; ++l) {
    const auto& part = model.coil_sets[static_cast<std::size_t>(l)];
    gain.middleCols<2>(2 * l) = part.a_N_per_A * std::cos(theta) + part.b_N_per_A * std::sin(theta);
    gain.col(2 * l) += network(part.column_a);
    gain.col(2 * l + 1) += network(part.column_b);
    cogging += network(part.cogging) / count;
    // Physics-part harmonics, with std::cos(nθ) and std::sin(nθ).
    for (std::size_t k = 0; k < model.harmonics.gain.size(); ++k) {
      const double n = model.harmonics.gain[k];
      const auto c = static_cast<Eigen::Index>(4 * k);
      gain.middleCols<2>(2 * l) += part.gain_harmonics_N_per_A.middleCols<2>(c) * std::cos(n * theta) +
                                   part.gain_harmonics_N_per_A.middleCols<2>(c + 2) * std::sin(n * theta);
    }
    for (std::size_t k = 0; k < model.harmonics.cogging.size(); ++k) {
      const double m = model.harmonics.cogging[k];
      const auto c = static_cast<Eigen::Index>(2 * k);
      cogging += (part.cogging_harmonics_N.col(c) * std::cos(m * theta) +
                  part.cogging_harmonics_N.col(c + 1) * std::sin(m * theta)) / count;
    }
  }
}

}  // namespace

TEST_CASE("tanh_array agrees with std::tanh to 1e-13 relative over a dense grid", "[network][tanh]") {
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

TEST_CASE("tanh_array keeps signed zeros and saturates infinities, NaN stays NaN", "[network][tanh]") {
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> x = {0.0, -0.0, inf, -inf, 1e300, -1e300, 22.0, -19.5, nan};
  std::vector<double> y(x.size());
  tanh_array(x.data(), y.data(), static_cast<int>(x.size()));
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

TEST_CASE("tanh_array handles every length and works in place", "[network][tanh]") {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> value(-5.0, 5.0);
  for (int count = 0; count <= 13; ++count) {
    std::vector<double> x(static_cast<std::size_t>(count) + 2, 42.0);  // guards after the end
    for (int k = 0; k < count; ++k) x[static_cast<std::size_t>(k)] = value(rng);
    const std::vector<double> original = x;
    tanh_array(x.data(), x.data(), count);
    for (int k = 0; k < count; ++k) {
      const auto i = static_cast<std::size_t>(k);
      REQUIRE(relative_error(x[i], std::tanh(original[i])) <= 1e-13);
    }
    REQUIRE(x[static_cast<std::size_t>(count)] == 42.0);
    REQUIRE(x[static_cast<std::size_t>(count) + 1] == 42.0);
  }
}

TEST_CASE("fused and per-network PGNN evaluation both match the model written out with std::tanh",
          "[network][model]") {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> position(-0.15, 0.15);
  // The paper's model, the field harmonics, and the highest orders allowed.
  const HarmonicOrders none, field{{5, 7}, {1, 2, 3, 4, 5, 6}}, highest{{2, kMaxHarmonicOrder}, {kMaxHarmonicOrder}};
  for (int coil_sets : {1, 2, 3, 5, 8}) {
    // Widths that are and are not multiples of the 4 lanes.
    for (const auto& [column, cog, harmonics] : {std::tuple{std::vector<int>{2}, std::vector<int>{16}, none},
                                                 std::tuple{std::vector<int>{3}, std::vector<int>{7}, field},
                                                 std::tuple{std::vector<int>{1}, std::vector<int>{64}, highest}}) {
      const auto model = test::random_pgnn_model(coil_sets, 0.032, rng, column, cog, harmonics);
      model.validate();
      REQUIRE(FusedPgnnEvaluator::supports(model));
      const FusedPgnnEvaluator fused(model);
      for (int trial = 0; trial < 200; ++trial) {
        const double y = position(rng);
        StackedGain expected_gain, plain_gain, fused_gain;
        Wrench expected_cogging, plain_cogging, fused_cogging;
        reference_evaluate(model, y, expected_gain, expected_cogging);
        model.evaluate(y, plain_gain, plain_cogging);
        fused.evaluate(y, fused_gain, fused_cogging);
        const double gain_scale = expected_gain.norm();
        const double cogging_scale = 1.0 + expected_cogging.norm();
        REQUIRE((plain_gain - expected_gain).norm() <= 1e-13 * gain_scale);
        REQUIRE((fused_gain - expected_gain).norm() <= 1e-13 * gain_scale);
        REQUIRE((plain_cogging - expected_cogging).norm() <= 1e-13 * cogging_scale);
        REQUIRE((fused_cogging - expected_cogging).norm() <= 1e-13 * cogging_scale);
      }
    }
  }
}

TEST_CASE("tanh_array gives bit-identical results on the AVX2 and the baseline path", "[network][tanh]") {
  INFO("this CPU " << (detail::tanh_array_uses_avx2() ? "takes" : "does not take") << " the AVX2 path");
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> value(-25.0, 25.0);
  std::vector<double> x(100'003);  // not a multiple of 4 or 8: every tail
  for (auto& v : x) v = value(rng);
  for (int k = 0; k < 64; ++k) x[static_cast<std::size_t>(k)] = std::ldexp(1.0, -k * 16);
  std::vector<double> dispatched(x.size()), baseline(x.size());
  for (int count : {0, 1, 2, 3, 5, 7, 9, 100'003}) {
    tanh_array(x.data(), dispatched.data(), count);
    detail::tanh_array_baseline(x.data(), baseline.data(), count);
    for (int k = 0; k < count; ++k) {
      const auto i = static_cast<std::size_t>(k);
      REQUIRE(std::memcmp(&dispatched[i], &baseline[i], sizeof(double)) == 0);
    }
  }
}
