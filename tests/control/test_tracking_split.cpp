// The live split of a tracking error by the commutation's frequencies
// (daemon/control/tracking_split.hpp) against a loop run independently: the
// PidController at 1 kHz around the mass, integrated in 50 substeps with the
// force evaluated at the position as it moves within each period, and
// recording noise of known variance added. The split must find the force's
// tracking error and the noise's variance, and almost nothing where there is
// no force.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "daemon/control/tracking_split.hpp"

using namespace clm::control;

namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kPitch_m = 0.03, kMass_kg = 15.0, kPeriod_s = 1e-3;

struct Recorded {
  std::vector<double> position_m, feedforward_N, tracking_error_m;
  double force_error_mse_m2 = 0.0;  ///< the force error's tracking error alone, before the noise
};

/// The axis follows r(t) = 0.06·sin(2π·t) (±2.4 m/s² at most): the loop
/// asks for F* = m·r'' + the PID's force, and the motor makes
/// F*·(1 + g(y)) + c(y), with a gain error g(y) = g₁cos(2πy/d + 0.5) and a
/// force c(y) = a₁cos(2πy/d) + a₆sin(12πy/d) + b·e^(−(y/20 mm)²) (a ripple
/// and a slow bump, as cogging along the stroke). The deviation from r obeys
/// m·x'' = PID + g(y)·F* + c(y); its error is recorded with white noise of
/// `noise_m` (1σ); the split is given the feedforward m·r'' as the daemon records
/// it (u_ff_N). A force disturbance of `disturbance_N` RMS (white noise
/// through a 20 Hz first-order low-pass, held over each period: the floor's
/// vibration, with power at the commutation's frequencies too) acts beside it.
Recorded record(double g1, double a1_N, double a6_N, double bump_N, double noise_m, double disturbance_N = 0.0) {
  const int cycles = 10000, substeps = 50;
  const double h = kPeriod_s / substeps, w = 2 * kPi;
  const auto reference = [&](double t) { return 0.06 * std::sin(w * t); };
  const auto acceleration = [&](double t) { return -0.06 * w * w * std::sin(w * t); };
  const auto force_error = [&](double y, double demand) {
    return g1 * std::cos(2 * kPi * y / kPitch_m + 0.5) * demand + a1_N * std::cos(2 * kPi * y / kPitch_m) +
           a6_N * std::sin(12 * kPi * y / kPitch_m) + bump_N * std::exp(-(y / 0.02) * (y / 0.02));
  };
  PidController pid(tune_pid(kMass_kg, 40.0), kPeriod_s);
  std::mt19937_64 random(7);
  std::normal_distribution<double> noise(0.0, noise_m);
  std::normal_distribution<double> white(0.0, 1.0);
  const double pole = std::exp(-2 * kPi * 20.0 * kPeriod_s);  // the low-pass per period
  double disturbance = 0.0;
  Recorded out;
  double x = 0.0, v = 0.0;  // the deviation from the reference
  for (int k = 0; k < cycles; ++k) {
    const double t = k * kPeriod_s;
    const double error = -x;
    const double force = pid.update(error);
    const double demand = kMass_kg * acceleration(t) + force;
    out.position_m.push_back(reference(t) + x);
    out.feedforward_N.push_back(kMass_kg * acceleration(t));
    out.tracking_error_m.push_back(error + noise(random));
    out.force_error_mse_m2 += error * error / cycles;
    disturbance = pole * disturbance + std::sqrt(1.0 - pole * pole) * disturbance_N * white(random);
    for (int j = 0; j < substeps; ++j) {  // midpoint: the force error where the axis is in the substep
      const double tm = t + (j + 0.5) * h;
      const double a = (force + disturbance + force_error(reference(tm) + x + 0.5 * v * h, demand)) / kMass_kg;
      x += v * h + 0.5 * a * h * h;
      v += a * h;
    }
  }
  return out;
}

TrackingSplit split(const Recorded& r) {
  return split_tracking_error(r.position_m, r.feedforward_N, r.tracking_error_m, kPitch_m, tune_pid(kMass_kg, 40.0),
                              kMass_kg, kPeriod_s);
}

}  // namespace

TEST_CASE("The live split finds a position-dependent force's tracking error and the noise's variance",
          "[control][tracking_split]") {
  const double noise_m = 2e-7;
  const Recorded r = record(0.03, 0.6, 0.2, 1.0, noise_m);
  const TrackingSplit s = split(r);
  INFO("force error " << r.force_error_mse_m2 << " m^2, noise " << noise_m * noise_m << " m^2; split: commutation "
                      << s.commutation_m2 << ", rest " << s.rest_m2 << ", total " << s.total_m2);
  REQUIRE(r.force_error_mse_m2 > noise_m * noise_m);  // the force error matters
  CHECK(s.commutation_m2 == Approx(r.force_error_mse_m2).epsilon(0.05));
  CHECK(s.rest_m2 == Approx(noise_m * noise_m).epsilon(0.05));
  CHECK(s.harmonics == kTrackingSplitHarmonics);
}

TEST_CASE("Without a ripple the live split gives the commutation almost nothing", "[control][tracking_split]") {
  const double noise_m = 2e-7;
  const Recorded r = record(0.0, 0.0, 0.0, 0.0, noise_m);
  const TrackingSplit s = split(r);
  INFO("commutation " << s.commutation_m2 << ", rest " << s.rest_m2);
  // Held out, what about 100 regressors fit by chance is not counted: the
  // commutation's share stays below the in-sample fit's expected 100/10 000.
  INFO(s.regressors << " regressors");
  CHECK(s.commutation_m2 < s.regressors / 10000.0 * s.total_m2);
  CHECK(s.rest_m2 == Approx(noise_m * noise_m).epsilon(0.05));
}

TEST_CASE("A band-limited force disturbance is not taken for the commutation's", "[control][tracking_split]") {
  // The disturbance's tracking error has power at the commutation's
  // frequencies and is correlated over tens of cycles: fitted in sample,
  // the shapes take a large part of it; held out they take little.
  const Recorded disturbed = record(0.0, 0.0, 0.0, 0.0, 0.0, 0.5);
  const TrackingSplit none = split(disturbed);
  INFO("disturbance alone: commutation " << none.commutation_m2 << ", rest " << none.rest_m2);
  CHECK(none.commutation_m2 < 0.1 * none.total_m2);
  // With the ripple beside it, the split finds the ripple's tracking error
  // (the same run without the disturbance) within 20 %.
  const Recorded ripple = record(0.03, 0.6, 0.2, 1.0, 0.0);
  const Recorded both = record(0.03, 0.6, 0.2, 1.0, 0.0, 0.5);
  const TrackingSplit s = split(both);
  INFO("ripple alone " << ripple.force_error_mse_m2 << " m^2; with the disturbance: commutation " << s.commutation_m2
                       << ", rest " << s.rest_m2 << ", total " << s.total_m2);
  REQUIRE(s.total_m2 > 1.5 * ripple.force_error_mse_m2);  // the disturbance matters
  CHECK(s.commutation_m2 == Approx(ripple.force_error_mse_m2).epsilon(0.2));
}

TEST_CASE("The live split refuses what it cannot fit", "[control][tracking_split]") {
  const PidGains gains = tune_pid(kMass_kg, 40.0);
  const std::vector<double> ten(10, 0.0), eleven(11, 0.0), many(1000, 0.0);
  std::vector<double> not_finite = many;
  not_finite[3] = std::nan("");
  CHECK_THROWS_AS(split_tracking_error(ten, ten, eleven, kPitch_m, gains, kMass_kg, kPeriod_s), std::invalid_argument);
  CHECK_THROWS_AS(split_tracking_error(ten, ten, ten, kPitch_m, gains, kMass_kg, kPeriod_s), std::invalid_argument);
  CHECK_THROWS_AS(split_tracking_error(many, many, many, 0.0, gains, kMass_kg, kPeriod_s), std::invalid_argument);
  CHECK_THROWS_AS(split_tracking_error(many, many, many, kPitch_m, gains, kMass_kg, kPeriod_s, 0), std::invalid_argument);
  CHECK_THROWS_AS(split_tracking_error(many, not_finite, many, kPitch_m, gains, kMass_kg, kPeriod_s),
                  std::invalid_argument);
  CHECK_NOTHROW(split_tracking_error(many, many, many, kPitch_m, gains, kMass_kg, kPeriod_s));
}
