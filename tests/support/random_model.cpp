#include "support/random_model.hpp"

namespace clm::test {

std::vector<ClassicalCoilSet> random_classical_coil_sets(int coil_sets, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> k(55.0, 65.0);
  std::uniform_real_distribution<double> zeta(-0.6, -0.4);
  std::vector<ClassicalCoilSet> result;
  for (int l = 0; l < coil_sets; ++l) {
    const double lever = coil_sets == 1 ? 0.02 : -0.06 + 0.12 * l / (coil_sets - 1);
    result.push_back({k(rng), zeta(rng), 0.15, lever});
  }
  return result;
}

namespace {
Network random_network(const std::vector<int>& hidden, double output_scale, std::mt19937_64& rng) {
  Network network = Network::zeros(hidden);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (std::size_t i = 0; i < network.layers.size(); ++i) {
    auto& layer = network.layers[i];
    const double scale = i + 1 == network.layers.size() ? output_scale : 2.0;
    for (Eigen::Index j = 0; j < layer.weights.size(); ++j) layer.weights.data()[j] = scale * normal(rng);
    for (Eigen::Index j = 0; j < layer.biases.size(); ++j) layer.biases[j] = scale * normal(rng);
  }
  return network;
}
}  // namespace

ElectromagneticModel random_pgnn_model(int coil_sets, double pole_pitch_m, std::mt19937_64& rng,
                                       const std::vector<int>& column_hidden,
                                       const std::vector<int>& cogging_hidden, const HarmonicOrders& harmonics) {
  const auto classical = random_classical_coil_sets(coil_sets, rng);
  ElectromagneticModel model = make_classical_model(pole_pitch_m, classical);
  model.normalisation = {0.0, 0.1};
  model.harmonics = harmonics;
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto gain_columns = static_cast<Eigen::Index>(4 * harmonics.gain.size());
  const auto cogging_columns = static_cast<Eigen::Index>(2 * harmonics.cogging.size());
  for (auto& coil_set : model.coil_sets) {
    coil_set.column_a = random_network(column_hidden, 1.0, rng);
    coil_set.column_b = random_network(column_hidden, 1.0, rng);
    coil_set.cogging = random_network(cogging_hidden, 0.5, rng);
    coil_set.gain_harmonics_N_per_A =
        Eigen::Matrix<double, 3, Eigen::Dynamic>::NullaryExpr(3, gain_columns, [&] { return 0.5 * normal(rng); });
    coil_set.cogging_harmonics_N =
        Eigen::Matrix<double, 3, Eigen::Dynamic>::NullaryExpr(3, cogging_columns, [&] { return 0.5 * normal(rng); });
  }
  return model;
}

ElectromagneticModel random_spline_model(int coil_sets, double pole_pitch_m, std::mt19937_64& rng) {
  const auto classical = random_classical_coil_sets(coil_sets, rng);
  ElectromagneticModel model = make_classical_model(pole_pitch_m, classical);
  model.kind = ModelKind::kSpline;
  model.spline_basis = {-0.12, 0.12, 24};
  std::normal_distribution<double> normal(0.0, 1.0);
  const int n = model.spline_basis.size();
  for (auto& coil_set : model.coil_sets) {
    coil_set.column_a_spline = SplineCoefficients::NullaryExpr(3, n, [&] { return 1.5 * normal(rng); });
    coil_set.column_b_spline = SplineCoefficients::NullaryExpr(3, n, [&] { return 1.5 * normal(rng); });
    coil_set.cogging_spline = SplineCoefficients::NullaryExpr(3, n, [&] { return 2.0 * normal(rng); });
  }
  return model;
}

}  // namespace clm::test
