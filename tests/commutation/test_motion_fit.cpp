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
