// Identification on synthetic data whose truth is known: the physics-only fit,
// eq. (31), Proposition 4.1, the PGNN and the spline model.
#include <catch2/catch.hpp>
#include <array>
#include <random>
#include <vector>

#include "commutation/identification/dataset.hpp"
#include "commutation/identification/linear_parameters.hpp"
#include "commutation/identification/pgnn_training.hpp"
#include "commutation/identification/physics_fit.hpp"
#include "commutation/identification/report.hpp"
#include "commutation/identification/spline_fit.hpp"
#include "support/random_model.hpp"

using namespace clm;
using namespace clm::identification;

namespace {

constexpr double kPolePitch = 0.032;
const DriveCommutation kDrive{67.0, -0.52};

// Coil set `coil_set` of `truth` driven alone with offsets ±π/4 along a
// back-and-forth sweep with varying magnitude, plus Gaussian force noise.
// Each group sweeps the stroke `sweeps` times (0.25: once, from 0 to 0.1 m).
CoilSetDataset synthetic_data(const ElectromagneticModel& truth, int coil_set, double noise_N, int samples_per_group,
                              std::mt19937_64& rng, double sweeps = 3.0) {
  std::normal_distribution<double> noise(0.0, noise_N);
  CoilSetDataset data;
  const auto n = 2 * samples_per_group;
  data.position_m.resize(n);
  data.currents_A.resize(2, n);
  data.wrench.resize(3, n);
  data.group.resize(static_cast<std::size_t>(n));
  for (int g = 0; g < 2; ++g) {
    const double delta = g == 0 ? -kPi / 4 : kPi / 4;
    for (int k = 0; k < samples_per_group; ++k) {
      const Eigen::Index t = g * samples_per_group + k;
      const double phase = 2.0 * kPi * sweeps * k / samples_per_group;
      const double y = 0.1 * std::sin(phase + 0.3 * g);
      const double magnitude = 40.0 * std::cos(phase * 1.7) + 15.0 * std::sin(phase * 0.37) + 5.0;
      const Eigen::Vector2d i = drive_phase_currents(kDrive, {magnitude, delta}, y, kPolePitch);
      CoilGain gain;
      Wrench cogging;
      truth.evaluate_coil_set(coil_set, y, gain, cogging);
      data.position_m[t] = y;
      data.currents_A.col(t) = i;
      data.wrench.col(t) = gain * i + cogging + Wrench(noise(rng), noise(rng), 0.02 * noise(rng));
      data.group[static_cast<std::size_t>(t)] = g;
    }
  }
  return data;
}

// Training and validation data: 20 % held out in contiguous blocks.
std::pair<CoilSetDataset, CoilSetDataset> held_out_blocks(const CoilSetDataset& all) {
  const auto split = split_contiguous_blocks(all, 0.2);
  return {all.subset(split.training), all.subset(split.validation)};
}

}  // namespace

TEST_CASE("physics-only fit recovers a classical coil set exactly", "[identification]") {
  std::mt19937_64 rng(40);
  const auto coil_sets = test::random_classical_coil_sets(3, rng);
  const auto truth = make_classical_model(kPolePitch, coil_sets);
  const auto data = synthetic_data(truth, 1, 0.0, 2000, rng);
  const PhysicsFit fit = fit_physics_only(data, kPolePitch, 0.0);
  const CoilGain& a = fit.a_N_per_A;
  const CoilGain& b = fit.b_N_per_A;
  CHECK((a - truth.coil_sets[1].a_N_per_A).cwiseAbs().maxCoeff() < 1e-9);
  CHECK((b - truth.coil_sets[1].b_N_per_A).cwiseAbs().maxCoeff() < 1e-9);
}

TEST_CASE("contiguous validation blocks hold out the requested share of each group", "[identification]") {
  std::mt19937_64 rng(41);
  const auto truth = make_classical_model(kPolePitch, test::random_classical_coil_sets(1, rng));
  const auto data = synthetic_data(truth, 0, 0.0, 1000, rng);
  const auto split = split_contiguous_blocks(data, 0.2);
  CHECK(split.validation.size() == 400);
  CHECK(split.training.size() == 1600);
  // Contiguity: the held-out indices of group 0 form two runs of 100.
  int runs = 0;
  for (std::size_t k = 0; k < split.validation.size(); ++k) {
    if (k == 0 || split.validation[k] != split.validation[k - 1] + 1) ++runs;
  }
  CHECK(runs == 4);
}

TEST_CASE("eq. (31) minimises the regularised cost over the linear parameters", "[identification]") {
  std::mt19937_64 rng(42);
  const auto truth = test::random_pgnn_model(1, kPolePitch, rng);
  const auto data = synthetic_data(truth, 0, 0.5, 1500, rng);
  const PositionNormalisation normalisation = truth.normalisation;
  const PhysicsFit fit = fit_physics_only(data, kPolePitch, 0.0);
  const CoilGain& pa = fit.a_N_per_A;
  const CoilGain& pb = fit.b_N_per_A;
  DirectionForce direction;
  // Hidden layers from a different random model; output layers solved.
  auto other = test::random_pgnn_model(1, kPolePitch, rng);
  CoilSetModel coil_set = other.coil_sets[0];
  solve_linear_parameters(data, kPolePitch, normalisation, {}, pa, pb, 0.1, coil_set, direction);
  ElectromagneticModel model = other;
  model.coil_sets[0] = coil_set;
  const auto regularised = [&](const ElectromagneticModel& m) {
    const auto& c = m.coil_sets[0];
    const double prior = 0.01 * ((c.a_N_per_A - pa).squaredNorm() + (c.b_N_per_A - pb).squaredNorm());
    return coil_set_cost(m, 0, data).sum() + prior;
  };
  const double optimum = regularised(model);
  // Any perturbation of a linear parameter raises the cost.
  for (double step : {1e-3, -1e-3}) {
    ElectromagneticModel perturbed = model;
    perturbed.coil_sets[0].a_N_per_A(0, 1) += step;
    CHECK(regularised(perturbed) > optimum);
    perturbed = model;
    perturbed.coil_sets[0].cogging.layers[1].weights(2, 5) += step;
    CHECK(regularised(perturbed) > optimum);
    perturbed = model;
    perturbed.coil_sets[0].column_b.layers[1].biases[1] += step;
    CHECK(regularised(perturbed) > optimum);
  }
  // Proposition 4.1 for arbitrary hidden layers: never worse than physics-only.
  ElectromagneticModel physics = model;
  physics.coil_sets[0].a_N_per_A = pa;
  physics.coil_sets[0].b_N_per_A = pb;
  for (auto* net : {&physics.coil_sets[0].column_a, &physics.coil_sets[0].column_b, &physics.coil_sets[0].cogging}) {
    for (auto& layer : net->layers) {
      layer.weights.setZero();
      layer.biases.setZero();
    }
  }
  CHECK(optimum <= coil_set_cost(physics, 0, data).sum());
}

TEST_CASE("PGNN identification fits a PGNN-structured coil set to the noise level", "[identification]") {
  std::mt19937_64 rng(43);
  const auto truth = test::random_pgnn_model(1, kPolePitch, rng);
  const double noise = 0.5;
  const auto all = synthetic_data(truth, 0, noise, 4000, rng);
  const auto [training, validation] = held_out_blocks(all);
  PgnnOptions options;
  options.restarts = 5;
  IdentificationReport report;
  const auto coil_set = identify_pgnn_coil_set(training, validation, kPolePitch, truth.normalisation, options, report);
  INFO("model y/x/z " << report.model_training.transpose() << " physics " << report.physics_training.transpose());
  for (int q = 0; q < 3; ++q) CHECK(report.proposition_holds[q]);
  // Noise variance is 0.25 N² in y and x; the physics-only model is far off.
  CHECK(report.physics_training[0] > 4 * report.model_training[0]);
  CHECK(report.model_training[0] < 1.2 * noise * noise);
  CHECK(report.model_validation[0] < 1.5 * noise * noise);
  CHECK(coil_set.column_a.hidden_sizes() == std::vector<int>{2});
  CHECK(coil_set.cogging.hidden_sizes() == std::vector<int>{16});
}

TEST_CASE("with held-out blocks that leave gaps in a single stroke, the model put to use is fit on every sample",
          "[identification]") {
  // One stroke per group: the validation blocks are stretches of the stroke
  // the training data never visit. The model put to use must predict the
  // truth there (noise-free) as well as anywhere, and the report must say
  // what it was fit on.
  std::mt19937_64 rng(46);
  const auto truth = test::random_pgnn_model(1, kPolePitch, rng);
  const double noise = 0.5;
  const auto all = synthetic_data(truth, 0, noise, 3000, rng, 0.25);
  const auto [training, validation] = held_out_blocks(all);
  PgnnOptions options;
  options.restarts = 3;
  IdentificationReport report;
  const auto coil_set = identify_pgnn_coil_set(training, validation, kPolePitch, truth.normalisation, options, report);
  ElectromagneticModel model = truth;
  model.coil_sets[0] = coil_set;
  CHECK(report.refit_on_all_data);
  CHECK(report.model_fit.sum() == Approx(coil_set_cost(model, 0, all).sum()).epsilon(1e-9));
  for (int q = 0; q < 3; ++q) CHECK(report.proposition_holds[q]);
  // Against the truth without noise, on the held-out stretches.
  DirectionCost gap_error = DirectionCost::Zero();
  for (Eigen::Index t = 0; t < validation.size(); ++t) {
    CoilGain gain, true_gain;
    Wrench cogging, true_cogging;
    model.evaluate_coil_set(0, validation.position_m[t], gain, cogging);
    truth.evaluate_coil_set(0, validation.position_m[t], true_gain, true_cogging);
    const Eigen::Vector2d i = validation.currents_A.col(t);
    gap_error += (gain * i + cogging - true_gain * i - true_cogging).cwiseAbs2();
  }
  gap_error /= static_cast<double>(validation.size());
  INFO("model put to use vs truth on the held-out stretches " << gap_error.transpose() << ", training-only model on "
       "them (with noise) " << report.model_validation.transpose());
  CHECK(gap_error[0] < 0.25 * noise * noise);  // well below the measurement noise
  CHECK(gap_error[1] < 0.25 * noise * noise);
}

TEST_CASE("variable projection and the joint Schur solve reach the same optimum of eq. (26)", "[identification]") {
  // The two solvers minimise the same cost from the same seeded starts; at
  // the noise level they must agree, and the reported eq. (26) must equal the
  // cost evaluated independently from the returned model.
  std::mt19937_64 rng(45);
  const auto truth = test::random_pgnn_model(1, kPolePitch, rng);
  const double noise = 0.5;
  const auto all = synthetic_data(truth, 0, noise, 4000, rng);
  const auto [training, validation] = held_out_blocks(all);
  PgnnOptions options;
  options.restarts = 3;
  double regularised[2];
  int k = 0;
  for (PgnnSolver solver : {PgnnSolver::kVariableProjection, PgnnSolver::kJointSchur}) {
    options.solver = solver;
    IdentificationReport report;
    const auto coil_set = identify_pgnn_coil_set(training, validation, kPolePitch, truth.normalisation, options, report);
    ElectromagneticModel model = truth;
    model.coil_sets[0] = coil_set;
    // The model put to use is fit on training and validation data together.
    CHECK(report.refit_on_all_data);
    const double data_term = coil_set_cost(model, 0, joined(training, validation)).sum();
    CHECK(report.model_fit.sum() == Approx(data_term).epsilon(1e-9));
    CHECK(report.model_training[0] < 1.2 * noise * noise);
    for (int q = 0; q < 3; ++q) CHECK(report.proposition_holds[q]);
    regularised[k++] = report.regularised_cost;
  }
  INFO("eq. (26): variable projection " << regularised[0] << ", joint " << regularised[1]);
  CHECK(regularised[0] == Approx(regularised[1]).epsilon(0.02));
}

TEST_CASE("PGNN with the field harmonics recovers a gain ripple and cogging at harmonics of the pole pitch",
          "[identification]") {
  // The truth: classical A, B plus 5th and 7th field harmonics in K and a
  // cogging Fourier series, with the networks zero. The paper's PGNN would
  // need a neuron per half-period of the ripple; with the harmonics in its
  // physics part the model class contains the truth.
  std::mt19937_64 rng(46);
  const HarmonicOrders harmonics = field_harmonic_orders();
  auto truth = test::random_pgnn_model(1, kPolePitch, rng, {2}, {4}, harmonics);
  auto& part = truth.coil_sets[0];
  for (Network* network : {&part.column_a, &part.column_b, &part.cogging}) {
    *network = Network::zeros(network->hidden_sizes());
  }
  part.gain_harmonics_N_per_A *= 2.0;  // about 1 N/A: a 2 % ripple on 60 N/A
  const double noise = 0.5;
  const auto all = synthetic_data(truth, 0, noise, 4000, rng);
  const auto [training, validation] = held_out_blocks(all);
  PgnnOptions options;
  options.column_hidden = 2;
  options.cogging_hidden = 4;
  options.regularisation = 0.01;
  IdentificationReport with_harmonics, without;
  options.harmonics = harmonics;
  const auto coil_set =
      identify_pgnn_coil_set(training, validation, kPolePitch, truth.normalisation, options, with_harmonics);
  options.harmonics = {};
  identify_pgnn_coil_set(training, validation, kPolePitch, truth.normalisation, options, without);
  INFO("validation y: with harmonics " << with_harmonics.model_validation[0] << ", without "
                                       << without.model_validation[0] << ", physics "
                                       << with_harmonics.physics_validation[0]);
  for (int q = 0; q < 3; ++q) CHECK(with_harmonics.proposition_holds[q]);
  CHECK(with_harmonics.model_training[0] < 1.2 * noise * noise);
  CHECK(with_harmonics.model_validation[0] < 1.5 * noise * noise);
  CHECK(without.model_validation[0] > 2.0 * with_harmonics.model_validation[0]);
  // The coefficients themselves, in the driving direction: within 0.1 N/A and 0.1 N.
  CHECK((coil_set.gain_harmonics_N_per_A.row(0) - part.gain_harmonics_N_per_A.row(0)).cwiseAbs().maxCoeff() < 0.1);
  CHECK((coil_set.cogging_harmonics_N.row(0) - part.cogging_harmonics_N.row(0)).cwiseAbs().maxCoeff() < 0.1);
}

TEST_CASE("spline identification recovers a spline-structured coil set", "[identification]") {
  std::mt19937_64 rng(44);
  auto truth = test::random_spline_model(1, kPolePitch, rng);
  const double noise = 0.5;
  const auto all = synthetic_data(truth, 0, noise, 6000, rng);
  const auto [training, validation] = held_out_blocks(all);
  SplineOptions options;
  options.knot_spacing_m = truth.spline_basis.spacing_m();
  IdentificationReport report;
  const auto basis = truth.spline_basis;  // the truth's own grid
  identify_spline_coil_set(training, validation, kPolePitch, basis, options, report);
  INFO("model " << report.model_training.transpose() << " validation " << report.model_validation.transpose());
  for (int q = 0; q < 3; ++q) CHECK(report.proposition_holds[q]);
  CHECK(report.model_training[0] < 1.2 * noise * noise);
  CHECK(report.model_validation[0] < 1.5 * noise * noise);
  CHECK(report.physics_training[0] > 5 * report.model_training[0]);
}

TEST_CASE("PGNN identification gives the same bits whatever cache sizes Eigen blocks its products for",
          "[identification][reproducibility]") {
  // Eigen sizes the blocks of a product's inner dimension from the CPU's
  // caches; the PGNN's sums over samples are the project's own, in sample
  // order (sample_sums.hpp), and so is its Levenberg–Marquardt, so a CPU
  // with another L1 or L2 must give the same model to the last bit
  // (docs/commutation.md, "Reproducibility"). 8000 samples: the sums are far
  // longer than any block.
  std::mt19937_64 rng(46);
  const auto truth = test::random_pgnn_model(1, kPolePitch, rng, {4}, {16}, identification::field_harmonic_orders());
  const auto all = synthetic_data(truth, 0, 0.5, 4000, rng);
  const auto [training, validation] = held_out_blocks(all);
  PgnnOptions options;
  options.restarts = 2;
  options.column_hidden = 4;
  options.harmonics = identification::field_harmonic_orders();
  const std::ptrdiff_t l1 = Eigen::l1CacheSize(), l2 = Eigen::l2CacheSize(), l3 = Eigen::l3CacheSize();
  std::vector<std::vector<double>> parameters;
  const std::array<std::array<std::ptrdiff_t, 3>, 3> caches = {
      {{16 * 1024, 256 * 1024, 2 * 1024 * 1024}, {32 * 1024, 1024 * 1024, 32 * 1024 * 1024},
       {48 * 1024, 2 * 1024 * 1024, 300 * 1024 * 1024}}};
  for (const auto& cache : caches) {
    Eigen::setCpuCacheSizes(cache[0], cache[1], cache[2]);
    IdentificationReport report;
    const auto coil_set = identify_pgnn_coil_set(training, validation, kPolePitch, truth.normalisation, options, report);
    std::vector<double> nonlinear;
    Eigen::Matrix<double, Eigen::Dynamic, 3> linear;
    pack_parameters(PgnnLayout::of(coil_set, options.harmonics), coil_set, report.direction_force, nonlinear, linear);
    nonlinear.insert(nonlinear.end(), linear.data(), linear.data() + linear.size());
    parameters.push_back(nonlinear);
  }
  Eigen::setCpuCacheSizes(l1, l2, l3);
  for (std::size_t k = 1; k < caches.size(); ++k) {
    INFO("L1 " << caches[k][0] / 1024 << " KiB against " << caches[0][0] / 1024 << " KiB");
    REQUIRE(parameters[k].size() == parameters[0].size());
    std::size_t differing = 0;
    for (std::size_t i = 0; i < parameters[0].size(); ++i) differing += parameters[k][i] != parameters[0][i];
    CHECK(differing == 0);
  }
}
