// Fit quality of identification (docs/commutation.md, "Fit quality"): the
// regressor condition against closed forms, unexcited parameters and
// excitation gaps against data built with known holes, and the spline and
// PGNN fits reporting both on such data.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "commutation/classical.hpp"
#include "commutation/identification/excitation.hpp"
#include "commutation/identification/linear_parameters.hpp"
#include "commutation/identification/pgnn_training.hpp"
#include "commutation/identification/spline_fit.hpp"

using namespace clm;
using namespace clm::identification;

namespace {

constexpr double kPolePitch = 0.032;
const DriveCommutation kDrive{67.0, -0.52};

/// A classical coil set driven with offsets ±π/4 along a sweep of [-0.1, 0.1] m
/// that skips (-0.03, 0.01) m, with no current in coil b on (0.05, 0.06) m
/// (the drive's angle is set so; the wrench is the classical truth).
CoilSetDataset holed_data(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> position(-0.1, 0.1);
  std::normal_distribution<double> noise(0.0, 0.3);
  const int n = 8000;
  CoilSetDataset data;
  data.position_m.resize(n);
  data.velocity_m_per_s = Eigen::VectorXd::Zero(n);
  data.currents_A.resize(2, n);
  data.wrench.resize(3, n);
  data.group.resize(n);
  const ClassicalEstimate truth{60.0, -0.5};
  for (int t = 0; t < n; ++t) {
    double y = position(rng);
    while (y > -0.03 && y < 0.01) y = position(rng);
    const double magnitude = 30.0 * std::sin(0.01 * t) + 10.0;
    const double delta = t % 2 == 0 ? -kPi / 4 : kPi / 4;
    Eigen::Vector2d i = drive_phase_currents(kDrive, {magnitude, delta}, y, kPolePitch);
    if (y > 0.05 && y < 0.06) i[1] = 0.0;
    data.position_m[t] = y;
    data.currents_A.col(t) = i;
    const double theta = 2.0 * kPi * y / kPolePitch + truth.phase_offset_rad;
    const double force = truth.motor_constant_N_per_A * (std::cos(theta) * i[0] + std::sin(theta) * i[1]);
    data.wrench.col(t) = Eigen::Vector3d(force + noise(rng), noise(rng), 0.01 * noise(rng));
    data.group[static_cast<std::size_t>(t)] = t % 2;
  }
  return data;
}

bool covers(const std::vector<ExcitationGap>& gaps, ExcitationLack lack, double low_m, double high_m) {
  for (const auto& gap : gaps) {
    if (gap.lack == lack && gap.low_m <= low_m && gap.high_m >= high_m) return true;
  }
  return false;
}

}  // namespace

TEST_CASE("the regressor condition is the closed form of two correlated columns, unexcited ones left out",
          "[fit-quality]") {
  for (const double rho : {0.0, 0.5, 0.99}) {
    // Columns scaled differently: the condition is of the scaled matrix.
    Eigen::MatrixXd gram(3, 3);
    gram << 4.0, 2.0 * rho * 3.0, 0.0,  //
        2.0 * rho * 3.0, 9.0, 0.0,      //
        0.0, 0.0, 0.0;                  // a column the data never touch
    const auto quality = regressor_quality(gram, {{0, 1}, {1, 1}, {2, 1}});
    CHECK(quality.parameters == 3);
    CHECK(quality.unexcited == 1);
    CHECK(quality.condition == Approx(std::sqrt((1.0 + rho) / (1.0 - rho))).epsilon(1e-9));
  }
  // In a group, a column far below the group's median is unexcited.
  Eigen::MatrixXd gram = Eigen::MatrixXd::Identity(5, 5);
  gram(4, 4) = 0.01;
  CHECK(regressor_quality(gram, {{0, 5}}).unexcited == 1);
  CHECK(regressor_quality(gram, {{0, 5}}).condition == Approx(1.0));
  CHECK(regressor_quality(gram, {{0, 4}, {4, 1}}).unexcited == 0);  // alone, it is judged absolutely
  CHECK_THROWS_AS(regressor_quality(gram, {{0, 4}}), std::invalid_argument);
  // A column duplicated (a saturated neuron beside its bias): one dependent direction.
  Eigen::MatrixXd twins = Eigen::MatrixXd::Identity(3, 3);
  twins(1, 2) = twins(2, 1) = 1.0;  // columns 1 and 2 are the same
  const auto dependent = regressor_quality(twins, {{0, 1}, {1, 1}, {2, 1}});
  CHECK(dependent.dependent == 1);
  CHECK(dependent.unexcited == 0);
  CHECK(dependent.condition == Approx(std::sqrt(2.0)));  // eigenvalues 2, 1 and the dependent 0
  // An uncounted column (beyond the data by construction) is never unexcited.
  Eigen::MatrixXd empty_end = gram;
  empty_end(4, 4) = 0.0;
  CHECK(regressor_quality(empty_end, {{0, 4}, {4, 1}}).unexcited == 1);
  CHECK(regressor_quality(empty_end, {{0, 4}, {4, 1, false}}).unexcited == 0);
}

TEST_CASE("excitation gaps find the stretch without samples and the one without a coil's current",
          "[fit-quality]") {
  std::mt19937_64 rng(3);
  const auto data = holed_data(rng);
  const auto gaps = excitation_gaps(data, kPolePitch);
  const double bin = kPolePitch / 8;
  // The holes, shrunk by a bin at each end (bins straddle their edges).
  CHECK(covers(gaps, ExcitationLack::kNoSamples, -0.03 + bin, 0.01 - bin));
  CHECK(covers(gaps, ExcitationLack::kNoCurrentB, 0.05 + bin, 0.06 - bin));
  // Nothing else: every gap lies within a hole, widened by a bin.
  for (const auto& gap : gaps) {
    INFO(describe(gap.lack) << " [" << gap.low_m << ", " << gap.high_m << "]");
    const bool in_sample_hole = gap.low_m >= -0.03 - bin && gap.high_m <= 0.01 + bin;
    const bool in_current_hole = gap.low_m >= 0.05 - bin && gap.high_m <= 0.06 + bin;
    CHECK((gap.lack == ExcitationLack::kNoSamples ? in_sample_hole : in_current_hole));
    CHECK(gap.lack != ExcitationLack::kNoCurrentA);
  }
  // Complete data: no gaps.
  std::uniform_real_distribution<double> position(-0.1, 0.1);
  CoilSetDataset full = data;
  for (Eigen::Index t = 0; t < full.size(); ++t) {
    full.position_m[t] = position(rng);
    full.currents_A.col(t) = drive_phase_currents(kDrive, {20.0, t % 2 ? kPi / 4 : -kPi / 4}, full.position_m[t],
                                                  kPolePitch);
  }
  CHECK(excitation_gaps(full, kPolePitch).empty());
  CHECK(identification_warnings({1.0, 10, 0, 0}, {}).empty());
}

TEST_CASE("the spline and the PGNN fits report the unexcited coefficients and the gaps of holed data",
          "[fit-quality]") {
  std::mt19937_64 rng(4);
  const auto data = holed_data(rng);
  SplineOptions spline_options;
  const auto basis = spline_basis_for(data.position_m, kPolePitch, spline_options);
  IdentificationReport spline;
  identify_spline_coil_set(data, {}, kPolePitch, basis, spline_options, spline);
  // The hole of 0.04 m spans 10 knot intervals of d_m/8: the cubic B-splines
  // wholly inside it (at least 10 − 3 per function, three functions) see no data.
  CHECK(spline.regressors.unexcited >= 3 * 7);
  CHECK(spline.regressors.parameters == 4 + 3 * basis.size());
  CHECK(spline.regressors.condition >= 1.0);
  CHECK(covers(spline.excitation_gaps, ExcitationLack::kNoSamples, -0.026, 0.006));
  const auto warnings = identification_warnings(spline.regressors, spline.excitation_gaps);
  REQUIRE(warnings.size() >= 3);
  CHECK_THAT(warnings[0], Catch::Contains("not excited"));

  PgnnOptions pgnn_options;
  pgnn_options.restarts = 2;
  pgnn_options.restart_iterations = 20;
  pgnn_options.final_iterations = 20;
  IdentificationReport pgnn;
  identify_pgnn_coil_set(data, {}, kPolePitch, normalisation_for(data.position_m), pgnn_options, pgnn);
  // The PGNN's linear part: the physics part, two column networks and the
  // cogging network's output layer, no direction term (zero velocity).
  CHECK(pgnn.regressors.parameters == 4 + 2 * (pgnn_options.column_hidden + 1) + pgnn_options.cogging_hidden + 1);
  CHECK(pgnn.regressors.condition >= 1.0);
  CHECK(pgnn.excitation_gaps.size() == spline.excitation_gaps.size());
}
