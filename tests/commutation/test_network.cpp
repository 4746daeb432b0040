// Both network evaluations (per network and fused) against the model written
// out with std::tanh.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <tuple>
#include <vector>

#include "commutation/model.hpp"
#include "support/random_model.hpp"

using namespace clm;

namespace {

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
