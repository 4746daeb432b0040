// Position-based identification of the driving direction (no force
// sensor): a synthetic motor whose positions come from an independent
// integration of its mechanics written here (not the project's simulator),
// with known mass, friction, gains and cogging; the fit must recover them.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "commutation/classical.hpp"
#include "commutation/identification/motion_fit.hpp"
#include "support/position_only_motor.hpp"

using namespace clm;
using namespace clm::identification;

namespace {

using test::PositionOnlyMotor;
constexpr double kPolePitch = PositionOnlyMotor::kPolePitch_m;

double rms_gain_error(const MotionFit& fit, const PositionOnlyMotor& truth) {
  double sum = 0.0;
  int count = 0;
  for (double y = -0.05; y <= 0.05; y += 2.5e-4, ++count) {
    sum += (fit.gain(y, kPolePitch, truth.basis) - truth.model.gain(y, kPolePitch, truth.basis)).squaredNorm() / 2.0;
  }
  return std::sqrt(sum / count);
}

double rms_cogging_error(const MotionFit& fit, const PositionOnlyMotor& truth) {
  double sum = 0.0;
  int count = 0;
  for (double y = -0.05; y <= 0.05; y += 2.5e-4, ++count) {
    const double e = fit.cogging_N(y, truth.basis) - truth.model.cogging_N(y, truth.basis);
    sum += e * e;
  }
  return std::sqrt(sum / count);
}

}  // namespace

TEST_CASE("mass, friction, gains and cogging come back from positions alone", "[motion-fit]") {
  std::mt19937_64 rng(11);
  for (const bool mass_known : {true, false}) {
    INFO((mass_known ? "mass given" : "mass identified, scale from the drive's nominal commutation"));
    // With the mass given, the truth's physics part differs from the
    // nominal one; without, the nominal commutation is the scale.
    const DriveCommutation drive = PositionOnlyMotor::nominal_drive();
    const PositionOnlyMotor truth(rng, mass_known ? 55.0 : drive.motor_constant_N_per_A,
                                  mass_known ? -0.45 : drive.phase_offset_rad);
    const std::vector<MotionRun> runs{truth.run(-kPi / 4, 12.0, 0.0), truth.run(kPi / 4, 12.0, 1.0)};
    MotionFitOptions options;
    options.drive = truth.drive;
    options.mass_kg = mass_known ? truth.mass_kg : 0.0;
    const MotionFit fit = fit_driving_direction_from_motion(runs, kPolePitch, truth.basis, options);
    INFO("mass " << fit.mass_kg << " f_v " << fit.viscous_N_s_per_m << " f_d " << fit.direction_N << " residual "
                 << fit.residual_rms_N << " N, gain error " << rms_gain_error(fit, truth) << " N/A, cogging error "
                 << rms_cogging_error(fit, truth) << " N");
    CHECK(fit.mass_kg == Approx(truth.mass_kg).epsilon(0.02));
    CHECK(fit.viscous_N_s_per_m == Approx(truth.viscous_N_s_per_m).epsilon(0.1));
    CHECK(fit.direction_N == Approx(truth.direction_N).epsilon(0.1));
    CHECK(rms_gain_error(fit, truth) < 0.5);     // of gains about 60 N/A
    CHECK(rms_cogging_error(fit, truth) < 0.3);  // of cogging about 1 N RMS
  }
}

TEST_CASE("the motion fit refuses runs of unequal steps and too few rows", "[motion-fit]") {
  MotionRun short_run;
  short_run.time_s = Eigen::VectorXd::LinSpaced(5, 0.0, 4e-3);
  short_run.position_m = Eigen::VectorXd::Zero(5);
  short_run.currents_A = Eigen::Matrix<double, 2, Eigen::Dynamic>::Zero(2, 5);
  MotionFitOptions options;
  options.drive = PositionOnlyMotor::nominal_drive();
  const UniformCubicBasis basis{-0.07, 0.07, 28};
  CHECK_THROWS_AS(fit_driving_direction_from_motion({short_run}, kPolePitch, basis, options), std::invalid_argument);
  short_run.time_s[3] = 3.5e-3;
  CHECK_THROWS_AS(fit_driving_direction_from_motion({short_run}, kPolePitch, basis, options), std::invalid_argument);
}

TEST_CASE("a known friction sets the scale from positions without the mass", "[motion-fit]") {
  std::mt19937_64 rng(13);
  // A physics part away from the nominal commutation, which therefore cannot
  // set the scale; the friction can.
  const PositionOnlyMotor truth(rng, 55.0, -0.45);
  const std::vector<MotionRun> runs{truth.run(-kPi / 4, 12.0, 0.0), truth.run(kPi / 4, 12.0, 1.0)};
  MotionFitOptions options;
  options.drive = truth.drive;
  options.viscous_N_s_per_m = truth.viscous_N_s_per_m;
  options.direction_N = truth.direction_N;
  const MotionFit fit = fit_driving_direction_from_motion(runs, kPolePitch, truth.basis, options);
  INFO("mass " << fit.mass_kg << " f_v " << fit.viscous_N_s_per_m << " f_d " << fit.direction_N << ", gain error "
               << rms_gain_error(fit, truth) << " N/A");
  CHECK(fit.mass_kg == Approx(truth.mass_kg).epsilon(0.03));
  CHECK(rms_gain_error(fit, truth) < 1.5);  // of gains about 55 N/A: the scale within 3 %
  // The mass and a friction together are refused: each fixes the scale.
  options.mass_kg = truth.mass_kg;
  CHECK_THROWS_AS(fit_driving_direction_from_motion(runs, kPolePitch, truth.basis, options), std::invalid_argument);
}

namespace {

/// The pairing weights by brute force: the hat around row k (time 0) times
/// each setpoint's share of the force, summed over 2·10⁵ midpoints; the
/// share of setpoint k − n is g(x − on) − g(x − off) with g the loop's step
/// response. Setpoints older than `kept` are added to the oldest kept.
PairingWeights brute_force_weights(double bandwidth_Hz, double delay_s, double period_s, int kept) {
  constexpr int kPoints = 200000;
  const double omega = 2.0 * kPi * bandwidth_Hz;
  const auto g = [&](double u) { return u < 0.0 ? 0.0 : bandwidth_Hz == 0.0 ? 1.0 : 1.0 - std::exp(-omega * u); };
  PairingWeights w;
  w.count = kept;
  const double dx = 2.0 * period_s / kPoints;
  for (int p = 0; p < kPoints; ++p) {
    const double x = -period_s + (p + 0.5) * dx;
    const double hat = (period_s - std::abs(x)) / (period_s * period_s) * dx;
    for (int n = 0; n < 40; ++n) {
      const double on = -n * period_s + delay_s;
      const double share = g(x - on) - g(x - on - period_s);
      const bool own = (n == 0 && x > 0.0) || (n == 1 && x < 0.0);
      const auto u = static_cast<std::size_t>(std::min(n, kept - 1));
      (own && n < kept ? w.own[u] : w.later[u]) += hat * share;
    }
  }
  return w;
}

}  // namespace

TEST_CASE("the pairing weights are the hat's integral over each setpoint's force", "[motion-fit]") {
  constexpr double kPeriod = 1e-3;
  const PairingWeights ideal = pairing_weights({}, 0.0, kPeriod);
  REQUIRE(ideal.count == 2);
  CHECK(ideal.own[0] == Approx(0.5).margin(1e-15));
  CHECK(ideal.own[1] == Approx(0.5).margin(1e-15));
  CHECK(ideal.later[0] == 0.0);
  CHECK(ideal.later[1] == 0.0);
  for (const double bandwidth_Hz : {0.0, 300.0, 750.0, 1500.0, 6000.0, 1e5}) {
    for (const double delay_s : {0.0, 0.3e-3, 1.2e-3}) {
      INFO("bandwidth " << bandwidth_Hz << " Hz, delay " << delay_s << " s");
      CurrentLoopModel loop;
      if (bandwidth_Hz > 0.0) loop = {bandwidth_Hz, 2.0, 1e-3};
      const PairingWeights w = pairing_weights(loop, delay_s, kPeriod);
      const PairingWeights expected = brute_force_weights(bandwidth_Hz, delay_s, kPeriod, w.count);
      double sum = 0.0;
      for (int n = 0; n < w.count; ++n) {
        const auto u = static_cast<std::size_t>(n);
        INFO("setpoint k - " << n);
        CHECK(w.own[u] == Approx(expected.own[u]).margin(2e-6));
        CHECK(w.later[u] == Approx(expected.later[u]).margin(2e-6));
        sum += w.own[u] + w.later[u];
      }
      CHECK(sum == Approx(1.0).margin(1e-12));
    }
  }
  CHECK_THROWS_AS(pairing_weights({}, -1e-4, kPeriod), std::invalid_argument);
  CHECK_THROWS_AS(pairing_weights({}, 0.0, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(pairing_weights({0.5, 2.0, 1e-3}, 0.0, kPeriod), std::invalid_argument);
}

TEST_CASE("the motion fit pairs positions with a current loop's lagged force", "[motion-fit]") {
  // A drive whose magnitude follows each setpoint through a 1.5 kHz loop
  // (a tenth of a 1 ms period) after 0.2 ms: the fit told the loop and the
  // delay finds the gains as well as on an ideal drive; told nothing, it
  // pairs each position with force the drive had not made yet.
  std::mt19937_64 rng(17);
  PositionOnlyMotor truth(rng, 55.0, -0.45);
  truth.current_loop_Hz = 1500.0;
  truth.delay_substeps = 4;
  const std::vector<MotionRun> runs{truth.run(-kPi / 4, 12.0, 0.0), truth.run(kPi / 4, 12.0, 1.0)};
  MotionFitOptions options;
  options.drive = truth.drive;
  options.mass_kg = truth.mass_kg;
  const MotionFit naive = fit_driving_direction_from_motion(runs, kPolePitch, truth.basis, options);
  options.current_loop = {truth.current_loop_Hz, 2.0, 1e-3};
  options.delay_s = truth.delay_substeps * PositionOnlyMotor::kPeriod_s / PositionOnlyMotor::kSubsteps;
  const MotionFit paired = fit_driving_direction_from_motion(runs, kPolePitch, truth.basis, options);
  INFO("gain error told the loop " << rms_gain_error(paired, truth) << " N/A, told nothing "
                                   << rms_gain_error(naive, truth) << " N/A; residual " << paired.residual_rms_N
                                   << " against " << naive.residual_rms_N << " N");
  CHECK(rms_gain_error(paired, truth) < 0.5);  // the ideal drive's bound, of gains about 55 N/A
  CHECK(rms_cogging_error(paired, truth) < 0.3);
  CHECK(rms_gain_error(paired, truth) < 0.5 * rms_gain_error(naive, truth));
}

TEST_CASE("a known payload gives the translator's mass from positions alone", "[motion-fit]") {
  // The same synthetic motor run without and with a payload of a third of
  // its mass; fitted per kilogram (mass 1 given) on the same grid, the ratio
  // of the two fits' force terms is (m + payload)/m.
  std::mt19937_64 rng(19);
  PositionOnlyMotor truth(rng, 55.0, -0.45);
  const double payload_kg = truth.mass_kg / 3.0;
  PositionOnlyMotor loaded = truth;
  loaded.mass_kg += payload_kg;
  MotionFitOptions options;
  options.drive = truth.drive;
  options.mass_kg = 1.0;
  const auto fit = [&](const PositionOnlyMotor& motor) {
    const std::vector<MotionRun> runs{motor.run(-kPi / 4, 12.0, 0.0), motor.run(kPi / 4, 12.0, 1.0)};
    return fit_driving_direction_from_motion(runs, kPolePitch, truth.basis, options);
  };
  const std::vector<MotionFit> without{fit(truth)}, with{fit(loaded)};
  const Eigen::VectorXd grid = Eigen::VectorXd::LinSpaced(401, -0.05, 0.05);  // the runs' range
  const PayloadMass found = mass_from_payload(without, with, payload_kg, grid, kPolePitch, truth.basis);
  INFO("ratio " << found.ratio << ", mass " << found.mass_kg << " kg of " << truth.mass_kg << " kg");
  CHECK(found.ratio == Approx(loaded.mass_kg / truth.mass_kg).epsilon(2e-3));
  CHECK(found.mass_kg == Approx(truth.mass_kg).epsilon(0.01));
  // No payload seen, a payload not positive, or lists that do not match: refused.
  CHECK_THROWS_WITH(mass_from_payload(without, without, payload_kg, grid, kPolePitch, truth.basis),
                    Catch::Contains("not slower"));
  CHECK_THROWS_AS(mass_from_payload(without, with, 0.0, grid, kPolePitch, truth.basis), std::invalid_argument);
  CHECK_THROWS_AS(mass_from_payload(without, {}, payload_kg, grid, kPolePitch, truth.basis), std::invalid_argument);
}
