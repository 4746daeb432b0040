// The validation score's standard error from held-out blocks, the paired
// difference of two laws, and the tie rule (tools/data/held_out_score.hpp),
// against figures computed by hand in the comments.
#include <catch2/catch.hpp>

#include <cmath>
#include <stdexcept>

#include "commutation/identification/dataset.hpp"
#include "tools/data/held_out_score.hpp"

using namespace clm;
using namespace clm::data;

namespace {

// One coil set of blocks whose physics-only error is 1 N² each.
std::vector<HeldOutBlock> unit_physics(const std::vector<double>& model_N2) {
  std::vector<HeldOutBlock> blocks;
  for (const double m : model_N2) blocks.push_back({m, 1.0});
  return blocks;
}

}  // namespace

TEST_CASE("per-sample squared errors are summed over the split's held-out blocks", "[held_out]") {
  Eigen::VectorXd squares(5);
  squares << 1.0, 2.0, 3.0, 4.0, 5.0;
  CHECK(block_sums(squares, {2, 3}) == std::vector<double>{3.0, 12.0});
  CHECK_THROWS_AS(block_sums(squares, {2, 2}), std::invalid_argument);
  CHECK_THROWS_AS(block_sums(squares, {2, 4}), std::invalid_argument);
  Eigen::VectorXd physics = Eigen::VectorXd::Constant(5, 2.0);
  const auto blocks = held_out_blocks(squares, physics, {2, 3});
  REQUIRE(blocks.size() == 2);
  CHECK(blocks[1].model_N2 == 12.0);
  CHECK(blocks[1].physics_N2 == 6.0);
}

TEST_CASE("the split names its held-out blocks: 2 of 10 per offset group at a fifth held out", "[held_out]") {
  identification::CoilSetDataset data;
  const int n = 200;
  data.position_m = Eigen::VectorXd::LinSpaced(n, 0.0, 1.0);
  data.currents_A = Eigen::Matrix<double, 2, Eigen::Dynamic>::Zero(2, n);
  data.wrench = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, n);
  for (int k = 0; k < n; ++k) data.group.push_back(k < 100 ? 0 : 1);
  const auto split = identification::split_contiguous_blocks(data, 0.2);
  // Blocks 2 and 7 of each group: indices 20..29, 70..79, 120..129, 170..179.
  CHECK(split.validation_blocks == std::vector<std::size_t>{10, 10, 10, 10});
  REQUIRE(split.validation.size() == 40);
  CHECK(split.validation[0] == 20);
  CHECK(split.validation[10] == 70);
  CHECK(split.validation[39] == 179);
  CHECK(identification::split_contiguous_blocks(data, 0.0).validation_blocks.empty());
}

TEST_CASE("with equal physics errors the standard error is that of the mean of the per-block ratios",
          "[held_out]") {
  // Ratios 0.1, 0.2, 0.3, 0.2: mean 0.2; deviations −0.1, 0, 0.1, 0, sum of
  // squares 0.02, sample variance 0.02/3, standard error √(0.02/3/4) = √(1/600).
  const ScoreEstimate score = held_out_score({unit_physics({0.1, 0.2, 0.3, 0.2})});
  CHECK(score.value == Approx(0.2).epsilon(1e-12));
  CHECK(score.standard_error == Approx(std::sqrt(1.0 / 600.0)).epsilon(1e-12));
  // The same physics error scaled by 4 changes neither ratio nor error.
  std::vector<HeldOutBlock> scaled = unit_physics({0.4, 0.8, 1.2, 0.8});
  for (auto& block : scaled) block.physics_N2 = 4.0;
  CHECK(held_out_score({scaled}).standard_error == Approx(std::sqrt(1.0 / 600.0)).epsilon(1e-12));
}

TEST_CASE("unequal blocks: the ratio estimator's linearised standard error, coil sets adding in variance",
          "[held_out]") {
  // (model, physics) = (1, 2), (3, 2), (2, 4): R = 6/8 = 0.75; z = (m − R·p)/8
  // = −0.0625, 0.1875, −0.125; Σz² = 0.0546875; SE² = 3/2 · 0.0546875.
  const std::vector<HeldOutBlock> first{{1.0, 2.0}, {3.0, 2.0}, {2.0, 4.0}};
  const ScoreEstimate one = held_out_score({first});
  CHECK(one.value == Approx(0.75).epsilon(1e-12));
  CHECK(one.standard_error == Approx(std::sqrt(1.5 * 0.0546875)).epsilon(1e-12));
  // A second coil set (the one above) adds 0.2 to the score and 1/600 to the variance.
  const ScoreEstimate two = held_out_score({first, unit_physics({0.1, 0.2, 0.3, 0.2})});
  CHECK(two.value == Approx(0.95).epsilon(1e-12));
  CHECK(two.standard_error == Approx(std::sqrt(1.5 * 0.0546875 + 1.0 / 600.0)).epsilon(1e-12));
  // A coil set without a positive physics error is left out, as the score leaves it out.
  CHECK(held_out_score({first, {{1.0, 0.0}, {1.0, 0.0}}}).value == Approx(0.75).epsilon(1e-12));
  // One block: no standard error.
  CHECK(std::isnan(held_out_score({{{1.0, 2.0}}}).standard_error));
  CHECK(std::isnan(held_out_score({}).value));
}

TEST_CASE("the paired difference cancels what two laws share on the same blocks", "[held_out]") {
  // b − a per block 0.01, 0.02, 0.01, 0.02: mean 0.015, deviations ±0.005,
  // sum of squares 1e-4, standard error √(1e-4/3/4); each score alone has √(1/600).
  const HeldOutBlocks a{unit_physics({0.1, 0.2, 0.3, 0.2})};
  const HeldOutBlocks b{unit_physics({0.11, 0.22, 0.31, 0.22})};
  const ScoreEstimate d = paired_difference(b, a);
  CHECK(d.value == Approx(0.015).epsilon(1e-9));
  CHECK(d.standard_error == Approx(std::sqrt(1e-4 / 12.0)).epsilon(1e-9));
  CHECK(d.standard_error < 0.1 * held_out_score(a).standard_error);
  CHECK(paired_difference(a, b).value == Approx(-0.015).epsilon(1e-9));
  // A constant shift: no uncertainty left.
  CHECK(paired_difference(HeldOutBlocks{unit_physics({0.2, 0.3, 0.4, 0.3})}, a).standard_error ==
        Approx(0.0).margin(1e-15));
  // Against the physics-only fit a law keeps its own standard error.
  const ScoreEstimate over_physics = paired_difference(a, physics_only(a));
  CHECK(over_physics.value == Approx(-0.8).epsilon(1e-12));
  CHECK(over_physics.standard_error == Approx(std::sqrt(1.0 / 600.0)).epsilon(1e-12));
  CHECK(held_out_score(physics_only(a)).value == 1.0);
  CHECK_THROWS_AS(paired_difference(a, HeldOutBlocks{unit_physics({0.1, 0.2, 0.3})}), std::invalid_argument);
}

namespace {

// The laws in the commissioning's order of preference, one coil set of four
// blocks with physics error 1 N² each.
std::vector<LawScore> laws(const std::vector<double>& spline, const std::vector<double>& position,
                           const std::vector<double>& pgnn) {
  const HeldOutBlocks s{unit_physics(spline)};
  return {law_score("classical", physics_only(s)), law_score("spline", s),
          law_score("spline-position", HeldOutBlocks{unit_physics(position)}),
          law_score("pgnn", HeldOutBlocks{unit_physics(pgnn)})};
}

}  // namespace

TEST_CASE("a tie goes to the first law in the order of preference, with a negative margin", "[held_out]") {
  // spline 0.2, spline-position 0.1975 (per block −0.02, +0.03, −0.03, +0.01:
  // mean −0.0025, deviations −0.0175, 0.0325, −0.0275, 0.0125, sum of squares
  // 0.002275, standard error √(0.002275/12) = 0.01377): a tie, and the spline
  // comes first.
  const Verdict verdict =
      choose_law(laws({0.30, 0.10, 0.25, 0.15}, {0.28, 0.13, 0.22, 0.16}, {0.5, 0.4, 0.6, 0.5}));
  CHECK(verdict.recommended == "spline");
  CHECK(verdict.tie);
  CHECK(verdict.tied == std::vector<std::string>{"spline", "spline-position"});
  CHECK(verdict.runner_up == "spline-position");
  CHECK(verdict.margin_score == Approx(-0.0025).epsilon(1e-9));
  CHECK(verdict.margin_standard_errors == Approx(-0.0025 / std::sqrt(0.002275 / 12.0)).epsilon(1e-9));
}

TEST_CASE("a clear win goes to the lowest score even when it is last in the order of preference", "[held_out]") {
  // pgnn 0.075 against the spline's 0.2: per block −0.2, −0.05, −0.17, −0.08,
  // mean −0.125, sum of squared deviations 0.0153, standard error √(0.0153/12)
  // = 0.0357: 3.5 standard errors.
  const Verdict verdict =
      choose_law(laws({0.30, 0.10, 0.25, 0.15}, {0.5, 0.4, 0.6, 0.5}, {0.10, 0.05, 0.08, 0.07}));
  CHECK(verdict.recommended == "pgnn");
  CHECK_FALSE(verdict.tie);
  CHECK(verdict.tied.empty());
  CHECK(verdict.runner_up == "spline");
  CHECK(verdict.margin_score == Approx(0.125).epsilon(1e-9));
  CHECK(verdict.margin_standard_errors == Approx(0.125 / std::sqrt(0.0153 / 12.0)).epsilon(1e-9));
}

TEST_CASE("a model that beats the physics-only fit by less than the noise leaves the classical law",
          "[held_out]") {
  // The spline's 0.95 with standard error √(0.13/12) = 0.104: 0.48 standard
  // errors below the physics-only 1; the others score above 1.
  const Verdict verdict = choose_law(laws({0.9, 1.2, 0.7, 1.0}, {1.1, 1.3, 1.2, 1.1}, {1.4, 1.2, 1.3, 1.5}));
  CHECK(verdict.recommended == "classical");
  CHECK(verdict.runner_up == "spline");
  CHECK(verdict.margin_score == Approx(-0.05).epsilon(1e-9));
  CHECK(verdict.margin_standard_errors == Approx(-0.05 / std::sqrt(0.13 / 12.0)).epsilon(1e-9));
  // The same spline far enough below 1 is recommended.
  CHECK(choose_law(laws({0.2, 0.3, 0.25, 0.25}, {1.1, 1.3, 1.2, 1.1}, {1.4, 1.2, 1.3, 1.5})).recommended == "spline");
}

TEST_CASE("without held-out blocks only equal scores tie, no laws or a NaN score is refused", "[held_out]") {
  const double nan = std::nan("");
  const Verdict verdict = choose_law({{"classical", {}, {3.0, 0.0}}, {"spline", {}, {0.36, nan}},
                                      {"pgnn", {}, {0.35, nan}}});
  CHECK(verdict.recommended == "pgnn");
  CHECK_FALSE(verdict.tie);
  CHECK(std::isnan(verdict.margin_standard_errors));
  CHECK(choose_law({{"spline", {}, {0.35, nan}}, {"pgnn", {}, {0.35, nan}}}).recommended == "spline");
  CHECK_THROWS_AS(choose_law({}), std::invalid_argument);
  CHECK_THROWS_AS(choose_law({{"spline", {}, {nan, nan}}}), std::invalid_argument);
}
