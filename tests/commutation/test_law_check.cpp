// What a law costs (counted, not timed) against the loop's budget, and
// whether its gains are a motor's: calibrations and models on the stroke.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "commutation/law_check.hpp"
#include "support/random_model.hpp"

using namespace clm;

namespace {

constexpr double kPolePitch = 0.03;
// The limits of config/servod.yaml with config/motor-sim.yaml.
const LawLimits kLimits{1000.0, 67.0, -0.12, 0.12};

std::vector<ClassicalCoilSet> sim_coil_sets() {
  // config/motor-sim.yaml's truth, with its orthogonal ratio.
  return {{61.3, -0.54, 0.1, -0.08}, {61.6, -0.55, 0.1, 0.0}, {60.1, -0.55, 0.1, 0.08}};
}

}  // namespace

TEST_CASE("A network's cost is its multiply-adds plus its tanh at their stated weight", "[law_check]") {
  // 1 → 5 → 7 → 3: weights 5 + 35 + 21, and 5 + 7 hidden neurons.
  CHECK(network_cost(Network::zeros({5, 7})) == 5 + 35 + 21 + 12 * kTanhMultiplyAdds);
  CHECK(network_cost(Network::zeros({5, 7})) == 301);  // with the stated 20 per tanh
  CHECK(network_cost(Network{}) == 0);
}

TEST_CASE("A PGNN law's cost counts the angle, each coil set's parts and networks, and the inverse", "[law_check]") {
  const auto coil_sets = sim_coil_sets();
  ElectromagneticModel model = make_classical_model(kPolePitch, coil_sets, {2}, {16});
  // Per coil set: column networks 2 + 6 + 2 tanh each, cogging 16 + 48 + 16 tanh,
  // physics part 12, inverse 80; once: sin_cos 40, inverse 300.
  const std::int64_t column = 2 + 6 + 2 * 20;
  const std::int64_t cogging = 16 + 48 + 16 * 20;
  CHECK(model_law_cost(model) == 40 + 300 + 3 * (2 * column + cogging + 12 + 80));

  // Harmonics: the recurrence to order 7 (4 each), per coil set 12 per gain
  // order and 6 per cogging order.
  model.harmonics = {{5, 7}, {1, 2, 6}};
  for (auto& part : model.coil_sets) {
    part.gain_harmonics_N_per_A = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, 8);
    part.cogging_harmonics_N = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, 6);
  }
  CHECK(model_law_cost(model) == 40 + 300 + 4 * 7 + 3 * (2 * column + cogging + 12 + 80 + 2 * 12 + 3 * 6));
}

TEST_CASE("A spline law's cost is the basis once and twelve per spline", "[law_check]") {
  std::mt19937_64 rng(11);
  const ElectromagneticModel model = test::random_spline_model(2, kPolePitch, rng);
  CHECK(model_law_cost(model) == 40 + 300 + 25 + 2 * (3 * 12 + 12 + 80));
  CHECK(classical_law_cost(3) == 40 + 3 * (2 * 40 + 20));
}

TEST_CASE("The budget is the stated rate times the law's share of the period", "[law_check]") {
  CHECK(law_cost_budget(1000.0) == 25000);  // 2.5e8/s · 0.1 · 1 ms
  CHECK(law_cost_budget(20000.0) == 1250);
  CHECK(law_cost_budget(10.0) == 2500000);
}

TEST_CASE("A 70 x 64 PGNN is refused at 1 kHz, the commissioning capacities and splines pass far inside",
          "[law_check]") {
  std::mt19937_64 rng(3);
  const std::vector<int> deep(70, 64);
  const ElectromagneticModel found = test::random_pgnn_model(3, kPolePitch, rng, deep, deep);
  const LawCheck refused = check_model_law(found, kLimits);
  REQUIRE(refused.verdict == LawVerdict::kTooCostly);
  // Per network 64 + 69·64² + 3·64 multiply-adds and 70·64 tanh; 9 networks.
  const double per_network = 64 + 69 * 4096 + 192 + 70 * 64 * 20;
  CHECK(refused.value == 340 + 9 * per_network + 3 * (12 + 80));
  CHECK(refused.value > 100 * refused.upper);
  CHECK(describe(refused) == "costs 3352936 multiply-adds per cycle, budget 25000 at 1000 Hz");

  // The paper's 2/16 on three coil sets, the largest capacity clm commission
  // tries (16/32 with its field harmonics, identification::field_harmonic_orders)
  // on four, and a spline on four.
  const ElectromagneticModel paper = test::random_pgnn_model(3, kPolePitch, rng);
  const ElectromagneticModel largest =
      test::random_pgnn_model(4, kPolePitch, rng, {16}, {32}, HarmonicOrders{{5, 7}, {1, 2, 3, 4, 5, 6}});
  const ElectromagneticModel spline = test::random_spline_model(4, kPolePitch, rng);
  CHECK(check_model_law(paper, kLimits).accepted());
  CHECK(check_model_law(largest, kLimits).accepted());
  CHECK(check_model_law(spline, kLimits).accepted());
  CHECK(model_law_cost(paper) == 2056);     // the figures docs/servod.md gives
  CHECK(model_law_cost(largest) == 7120);
  CHECK(model_law_cost(spline) == 877);
  // As the daemon uses them, blended to the classical law outside their
  // range (commutation/range_blend.hpp): both laws and the blend.
  CHECK(blended_law_cost(paper) == 2596);
  CHECK(blended_law_cost(largest) == 7810);
  CHECK(blended_law_cost(spline) == 1567);
  CHECK(blended_law_cost(found) == 3353476);
  CHECK(3 * blended_law_cost(largest) < law_cost_budget(1000.0));
  CHECK(10 * model_law_cost(paper) < law_cost_budget(1000.0));
  CHECK(3 * model_law_cost(largest) < law_cost_budget(1000.0));
  CHECK(25 * model_law_cost(spline) < law_cost_budget(1000.0));
}

TEST_CASE("The model's motor constant of a classical coil set is k at every position", "[law_check]") {
  const ClassicalCoilSet coil_set{61.3, -0.54, 0.1, -0.08};
  for (double y = -0.05; y <= 0.05; y += 0.0011) {
    CHECK(driving_force_gain_N_per_A(classical_gain(coil_set, y, kPolePitch)) == Approx(61.3).epsilon(1e-12));
  }
}

TEST_CASE("A calibration with k = 1e-300 on one coil set is refused naming the coil set", "[law_check]") {
  std::vector<ClassicalEstimate> estimates{{61.3, -0.54}, {1e-300, -0.55}, {60.1, -0.55}};
  const LawCheck check = check_classical_law(estimates, kLimits);
  REQUIRE(check.verdict == LawVerdict::kGainOutOfRange);
  CHECK(check.coil_set == 2);
  CHECK(check.value == 1e-300);
  CHECK(describe(check) == "coil set 2: motor constant 1e-300 N/A outside [6.7, 670] N/A");

  estimates[1].motor_constant_N_per_A = 671.0;
  CHECK(check_classical_law(estimates, kLimits).coil_set == 2);
  estimates[1].motor_constant_N_per_A = std::numeric_limits<double>::infinity();
  CHECK(check_classical_law(estimates, kLimits).verdict == LawVerdict::kGainNotFinite);
  estimates[1].motor_constant_N_per_A = 61.6;
  CHECK(check_classical_law(estimates, kLimits).accepted());
  // Ten times off either way is still a motor; further is not.
  estimates[0].motor_constant_N_per_A = 6.7;
  estimates[2].motor_constant_N_per_A = 670.0;
  CHECK(check_classical_law(estimates, kLimits).accepted());
}

TEST_CASE("A model with one coil set's gain zeroed is refused naming the coil set and the position", "[law_check]") {
  const auto coil_sets = sim_coil_sets();
  ElectromagneticModel model = make_classical_model(kPolePitch, coil_sets, {2}, {16});
  REQUIRE(check_model_law(model, kLimits).accepted());

  // Zero everywhere: refused at the stroke's lower end, the first point.
  model.coil_sets[2].a_N_per_A.setZero();
  model.coil_sets[2].b_N_per_A.setZero();
  const LawCheck check = check_model_law(model, kLimits);
  REQUIRE(check.verdict == LawVerdict::kGainOutOfRange);
  CHECK(check.coil_set == 3);
  CHECK(check.position_m == -0.12);
  CHECK(check.value == 0.0);
  CHECK(describe(check) == "coil set 3 at y = -0.12 m: motor constant 0 N/A outside [6.7, 670] N/A");

  // Zero above y = 0 only: coil set 3's physics part zero, its column a a
  // step network 30 − 30·tanh(10⁴·y) (input y/0.2, identified on ±0.2 m,
  // so the whole stroke is sampled), so K_y = [v, 0] and the
  // motor constant is v: 30 N/A at y = 0, 30·(1 − tanh 9.375) ≈ 60·e^−18.75
  // one grid step (0.24 m / 256) above it.
  model.normalisation = {0.0, 0.2};
  Network step = Network::zeros({1});
  step.layers[0].weights(0, 0) = 2000.0;
  step.layers[1].weights(0, 0) = -30.0;
  step.layers[1].biases[0] = 30.0;
  model.coil_sets[2].column_a = step;
  const LawCheck half = check_model_law(model, kLimits);
  REQUIRE(half.verdict == LawVerdict::kGainOutOfRange);
  CHECK(half.coil_set == 3);
  CHECK(half.position_m == Approx(0.24 / 256).epsilon(1e-12));
  CHECK(half.value == Approx(60.0 * std::exp(-18.75)).epsilon(1e-6));
}

TEST_CASE("A coil set's motor constant below a tenth of the nominal is refused, above it accepted", "[law_check]") {
  auto coil_sets = sim_coil_sets();
  coil_sets[1].motor_constant_N_per_A = 5.0;  // below 67/10
  const LawCheck low = check_model_law(make_classical_model(kPolePitch, coil_sets), kLimits);
  REQUIRE(low.verdict == LawVerdict::kGainOutOfRange);
  CHECK(low.coil_set == 2);
  CHECK(low.value == Approx(5.0).epsilon(1e-12));
  coil_sets[1].motor_constant_N_per_A = 7.0;
  CHECK(check_model_law(make_classical_model(kPolePitch, coil_sets), kLimits).accepted());
}

TEST_CASE("A model is judged where the law as used drives the axis: its range and the blend margin",
          "[law_check]") {
  // Coil set 2: physics part zero, column a the step 30 − 30·tanh(w·u + b)
  // of the input u = (y − offset)/scale, switching off at y = 0.05 m.
  const auto step_at = [](const PositionNormalisation& normalisation) {
    Network step = Network::zeros({1});
    const double w = 1000.0;
    step.layers[0].weights(0, 0) = w;
    step.layers[0].biases[0] = -w * (0.05 - normalisation.offset_m) / normalisation.scale_m;
    step.layers[1].weights(0, 0) = -30.0;
    step.layers[1].biases[0] = 30.0;
    return step;
  };
  ElectromagneticModel model = make_classical_model(kPolePitch, sim_coil_sets(), {1}, {16});
  model.coil_sets[1].a_N_per_A.setZero();
  model.coil_sets[1].b_N_per_A.setZero();
  const std::vector<ClassicalEstimate> calibration{{61.3, -0.54}, {61.6, -0.55}, {60.1, -0.55}};

  // Data on ±0.1 m: the step lies inside, refused above 0.05 m, blended or not.
  model.normalisation = {0.0, 0.1};
  model.coil_sets[1].column_a = step_at(model.normalisation);
  for (const LawCheck& refused : {check_model_law(model, kLimits), check_blended_law(model, calibration, kLimits)}) {
    REQUIRE(refused.verdict == LawVerdict::kGainOutOfRange);
    CHECK(refused.coil_set == 2);
    CHECK(refused.position_m > 0.05);
    CHECK(refused.position_m < 0.05 + 0.24 / 256);
  }

  // Data on −0.12..0.04 m: the step lies beyond them and beyond the blend's
  // margin (0.0075 m): the law as used is accepted, unblended it is not.
  model.normalisation = {-0.04, 0.08};
  model.coil_sets[1].column_a = step_at(model.normalisation);
  CHECK(check_blended_law(model, calibration, kLimits).accepted());
  CHECK(check_model_law(model, kLimits).verdict == LawVerdict::kGainOutOfRange);

  // Data on −0.12..0.045 m: the step lies 5 mm beyond them, inside the
  // margin where the model still drives the axis: refused.
  model.normalisation = {-0.0375, 0.0825};
  model.coil_sets[1].column_a = step_at(model.normalisation);
  CHECK(check_blended_law(model, calibration, kLimits).coil_set == 2);
}
