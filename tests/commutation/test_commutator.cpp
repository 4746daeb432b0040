// Analytic commutation (37) with true or paper minimum power, (39) setpoints,
// damping near singularity, and no allocation in the call.
#include <catch2/catch.hpp>
#include <Eigen/Dense>
#include <random>

#include "commutation/commutator.hpp"
#include "support/allocation_counter.hpp"
#include "support/random_model.hpp"

using namespace clm;

namespace {

constexpr double kPolePitch = 0.032;
const DriveCommutation kDrive{67.0, -0.52};

Wrench random_wrench(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> fy(-400.0, 400.0), fx(-20.0, 20.0), tz(-2.0, 2.0);
  return {fy(rng), fx(rng), tz(rng)};
}

// Independent reference: the weighted minimum-norm solution written out with
// generic dense matrices, i = W⁻¹Kᵀ(KW⁻¹Kᵀ)⁻¹(F* − F_cog).
Eigen::VectorXd reference_currents(const ElectromagneticModel& model, double y, const Wrench& desired,
                                   PowerMetric metric) {
  StackedGain gain;
  Wrench cogging;
  model.evaluate(y, gain, cogging);
  const Eigen::MatrixXd k = gain;
  const int n = static_cast<int>(k.cols());
  Eigen::MatrixXd w_inverse = Eigen::MatrixXd::Identity(n, n);
  if (metric == PowerMetric::kTruePower) {
    Eigen::Matrix2d w;
    w << 2, 1, 1, 2;
    for (int l = 0; l < n / 2; ++l) w_inverse.block<2, 2>(2 * l, 2 * l) = w.inverse();
  }
  const Eigen::Matrix3d normal = k * w_inverse * k.transpose();
  return w_inverse * k.transpose() * normal.inverse() * (desired - cogging);
}

}  // namespace

TEST_CASE("PGNN and spline commutation produce the desired wrench for L >= 2", "[commutator][property]") {
  std::mt19937_64 rng(20);
  std::uniform_real_distribution<double> position(-0.12, 0.12);
  for (int coil_sets : {2, 3, 4, 8}) {
    for (int kind = 0; kind < 3; ++kind) {
      // 0: paper-sized PGNN (fused evaluation), 1: spline, 2: two hidden layers (generic evaluation).
      const auto model = kind == 0   ? test::random_pgnn_model(coil_sets, kPolePitch, rng)
                         : kind == 1 ? test::random_spline_model(coil_sets, kPolePitch, rng)
                                     : test::random_pgnn_model(coil_sets, kPolePitch, rng, {4, 3}, {8, 8});
      for (auto metric : {PowerMetric::kTruePower, PowerMetric::kCurrentNorm}) {
        const ModelCommutator law(model, kDrive, {metric, PhaseConvention::kSignedMagnitude, 1e-6});
        CommutationOutput out;
        for (int trial = 0; trial < 500; ++trial) {
          const double y = position(rng);
          const Wrench desired = random_wrench(rng);
          law.commutate(y, desired, out);
          REQUIRE_FALSE(out.damping_engaged);
          const Wrench achieved = model.predict(y, out.currents_A);
          REQUIRE((achieved - desired).norm() < 1e-9 * desired.norm());
          const Eigen::VectorXd reference = reference_currents(model, y, desired, metric);
          REQUIRE((out.currents_A - reference).norm() < 1e-9 * (1.0 + reference.norm()));
        }
      }
    }
  }
}

TEST_CASE("for L = 1 the commutation is the least-squares wrench", "[commutator][property]") {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> position(-0.12, 0.12);
  const auto model = test::random_pgnn_model(1, kPolePitch, rng);
  const ModelCommutator law(model, kDrive);
  CommutationOutput out;
  for (int trial = 0; trial < 500; ++trial) {
    const double y = position(rng);
    const Wrench desired = random_wrench(rng);
    law.commutate(y, desired, out);
    StackedGain gain;
    Wrench cogging;
    model.evaluate(y, gain, cogging);
    // Normal equations: the residual is orthogonal to the columns of K̂.
    const Wrench residual = model.predict(y, out.currents_A) - desired;
    REQUIRE((gain.transpose() * residual).norm() < 1e-9 * gain.norm() * desired.norm());
    // And no other currents do better (perturbation check).
    for (int k = 0; k < 2; ++k) {
      CurrentVector perturbed = out.currents_A;
      perturbed[k] += 1e-3;
      REQUIRE((model.predict(y, perturbed) - desired).squaredNorm() >= residual.squaredNorm());
    }
  }
}

TEST_CASE("with zero networks and true power the model law is classical commutation", "[commutator]") {
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> position(-0.12, 0.12);
  std::uniform_real_distribution<double> force(-400.0, 400.0);
  for (int coil_sets : {2, 3, 5}) {
    const auto coil_set_parameters = test::random_classical_coil_sets(coil_sets, rng);
    const auto model = make_classical_model(kPolePitch, coil_set_parameters, {2}, {16});
    std::vector<ClassicalEstimate> estimates;
    for (const auto& p : coil_set_parameters) estimates.push_back({p.motor_constant_N_per_A, p.phase_offset_rad});
    const ModelCommutator law(model, kDrive);
    CommutationOutput out;
    for (int trial = 0; trial < 300; ++trial) {
      const double y = position(rng);
      const double fy = force(rng);
      law.commutate(y, {fy, 0.0, 0.0}, out);
      CurrentVector classical;
      classical_currents(estimates, kPolePitch, y, fy, classical);
      REQUIRE((out.currents_A - classical).norm() < 1e-9 * (1.0 + classical.norm()));
    }
  }
}

TEST_CASE("true-power currents never dissipate more than the paper's minimum-norm currents", "[commutator][property]") {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> position(-0.12, 0.12);
  double largest_saving = 0.0;
  for (int coil_sets : {2, 3, 4}) {
    const auto model = test::random_pgnn_model(coil_sets, kPolePitch, rng);
    const ModelCommutator true_power(model, kDrive, {PowerMetric::kTruePower});
    const ModelCommutator paper(model, kDrive, {PowerMetric::kCurrentNorm});
    CommutationOutput a, b;
    for (int trial = 0; trial < 1000; ++trial) {
      const double y = position(rng);
      const Wrench desired = random_wrench(rng);
      true_power.commutate(y, desired, a);
      paper.commutate(y, desired, b);
      REQUIRE(a.current_square_sum_A2 <= b.current_square_sum_A2 * (1.0 + 1e-12));
      // Dually, the paper's solution has the smaller ‖[i_a, i_b]‖².
      REQUIRE(b.currents_A.squaredNorm() <= a.currents_A.squaredNorm() * (1.0 + 1e-12));
      largest_saving = std::max(largest_saving, 1.0 - a.current_square_sum_A2 / b.current_square_sum_A2);
    }
  }
  CHECK(largest_saving > 0.01);  // the metrics do differ
}

TEST_CASE("setpoints make the fixed-commutation drive apply the commutation currents", "[commutator]") {
  std::mt19937_64 rng(24);
  std::uniform_real_distribution<double> position(-0.12, 0.12);
  const auto model = test::random_pgnn_model(3, kPolePitch, rng);
  const ModelCommutator law(model, kDrive);
  CommutationOutput out;
  for (int trial = 0; trial < 500; ++trial) {
    const double y = position(rng);
    law.commutate(y, random_wrench(rng), out);
    for (int l = 0; l < 3; ++l) {
      const Eigen::Vector2d applied = drive_phase_currents(kDrive, out.setpoints[l], y, kPolePitch);
      REQUIRE((applied - out.currents_A.segment<2>(2 * l)).norm() < 1e-10);
    }
  }
}

TEST_CASE("near-singular gain engages the damped inverse and says so", "[commutator]") {
  // μ = 0: no coil set produces F_x or T_z, so K̂ has rank 1 in force space.
  std::vector<ClassicalCoilSet> coil_sets = {{60.0, -0.5, 0.0, -0.05}, {60.0, -0.5, 0.0, 0.05}};
  const auto model = make_classical_model(kPolePitch, coil_sets);
  const ModelCommutator law(model, kDrive);
  CommutationOutput out;
  law.commutate(0.013, {100.0, 5.0, 0.5}, out);
  CHECK(out.damping_engaged);
  CHECK(out.singular_value_ratio < 1e-4);
  CHECK(out.currents_A.allFinite());
  // The achievable part of the demand is still met closely.
  CHECK(out.model_wrench[0] == Approx(100.0).epsilon(1e-6));
}

TEST_CASE("a commutation call does not allocate", "[commutator][realtime]") {
  std::mt19937_64 rng(25);
  const auto model = test::random_pgnn_model(3, kPolePitch, rng);
  const auto spline = test::random_spline_model(3, kPolePitch, rng);
  const ModelCommutator pgnn_law(model, kDrive);
  const ModelCommutator spline_law(spline, kDrive);
  const ClassicalEstimate estimates[3] = {{61.34, -0.54}, {61.62, -0.55}, {60.07, -0.55}};
  const ClassicalCommutator classical_law(estimates, kPolePitch, kDrive);
  const CommutationLaw* laws[3] = {&pgnn_law, &spline_law, &classical_law};
  CommutationOutput out;
  out.currents_A.resize(6);
  std::uniform_real_distribution<double> position(-0.12, 0.12);
  std::vector<double> positions(1000);
  for (auto& p : positions) p = position(rng);
  for (const auto* law : laws) {
    test::AllocationScope scope;
    for (int call = 0; call < 100000; ++call) {
      law->commutate(positions[static_cast<std::size_t>(call % 1000)], {100.0, 1.0, 0.1}, out);
    }
    CHECK(scope.allocations() == 0);
  }
}

TEST_CASE("each law reports its model's driving-force gain ∂F_y/∂i at the position", "[commutator]") {
  // The model law: row y of the model's gain; the classical law: row y of
  // classical_gain with its estimates, and the driving force its currents
  // make through that row is the demand.
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> position(-0.12, 0.12);
  const auto model = test::random_pgnn_model(3, kPolePitch, rng);
  const ModelCommutator model_law(model, kDrive);
  const std::vector<ClassicalEstimate> estimates{{61.0, -0.5}, {63.0, -0.45}, {59.0, -0.6}};
  const ClassicalCommutator classical_law(estimates, kPolePitch, kDrive);
  CommutationOutput out;
  for (int trial = 0; trial < 200; ++trial) {
    const double y = position(rng);
    const Wrench desired = random_wrench(rng);
    StackedGain gain;
    Wrench cogging;
    model.evaluate(y, gain, cogging);
    model_law.commutate(y, desired, out);
    REQUIRE((out.driving_gain_N_per_A - gain.row(0).transpose()).norm() < 1e-12 * gain.row(0).norm());
    classical_law.commutate(y, desired, out);
    for (int l = 0; l < 3; ++l) {
      const auto& e = estimates[static_cast<std::size_t>(l)];
      const Eigen::RowVector2d expected = classical_gain({e.motor_constant_N_per_A, e.phase_offset_rad, 0.0, 0.0}, y,
                                                         kPolePitch).row(0);
      INFO("y " << y << ", coil set " << l + 1);
      REQUIRE((out.driving_gain_N_per_A.segment<2>(2 * l).transpose() - expected).norm() < 1e-9 * expected.norm() + 1e-12);
    }
    REQUIRE(out.driving_gain_N_per_A.dot(out.currents_A) == Approx(desired.x()).margin(1e-9));
  }
}
