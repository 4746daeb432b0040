// The true electromagnetics: eq. (7) when the parasitics are off, and each
// parasitic with the shape and size its parameters say.
#include <catch2/catch.hpp>
#include <cmath>
#include <complex>
#include <vector>

#include "commutation/classical.hpp"
#include "drivers/sim/electromagnetics.hpp"
#include "drivers/sim/sim_support.hpp"

using namespace clm;
using namespace clm::sim;

namespace {

ClassicalCoilSet classical_of(const ElectromagneticParameters& em, int l, double extra_phase_rad = 0.0) {
  const auto& set = em.coil_sets[static_cast<std::size_t>(l)];
  return {set.motor_constant_N_per_A, set.phase_offset_rad + extra_phase_rad, em.orthogonal_ratio, set.lever_arm_m};
}

ElectromagneticTruth make_truth(const ElectromagneticParameters& em) { return ElectromagneticTruth(em, -0.11, 0.11); }

/// Complex Fourier coefficient of harmonic n of samples over one period.
std::complex<double> fourier(const std::vector<double>& samples, int n) {
  std::complex<double> sum = 0.0;
  const auto count = static_cast<double>(samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k) {
    sum += samples[k] * std::exp(std::complex<double>(0.0, -kTwoPi * n * static_cast<double>(k) / count));
  }
  return (n == 0 ? 1.0 : 2.0) * sum / count;
}

/// Driving force per newton of one coil set commutated with its true k and ζ
/// (eq. 12), at `samples` positions over one pole pitch.
std::vector<double> force_ratio_over_pole_pitch(const ElectromagneticTruth& truth, int l, int samples) {
  const auto& em = truth.parameters();
  const auto& set = em.coil_sets[static_cast<std::size_t>(l)];
  std::vector<double> ratio;
  for (int k = 0; k < samples; ++k) {
    const double y = em.pole_pitch_m * k / samples;
    const Eigen::Vector2d i = sinusoidal_currents(
        1.0, electrical_angle_rad(y, em.pole_pitch_m) + set.phase_offset_rad, set.motor_constant_N_per_A);
    ratio.push_back((truth.gain(l, y) * i).x());
  }
  return ratio;
}

}  // namespace

TEST_CASE("without parasitics the truth is the classical model (7) for any L and pole pitch", "[sim][electromagnetics]") {
  for (int coil_sets = 1; coil_sets <= 4; ++coil_sets) {
    for (double pole_pitch : {0.024, 0.032, 0.05}) {
      const MotorParameters motor = fixtures::ideal_motor(coil_sets, pole_pitch);
      const ElectromagneticTruth truth = make_truth(motor.electromagnetics);
      for (double y = -0.1; y <= 0.1; y += 0.00731) {
        for (int l = 0; l < coil_sets; ++l) {
          const CoilGain expected = classical_gain(classical_of(motor.electromagnetics, l), y, pole_pitch);
          REQUIRE((truth.gain(l, y) - expected).cwiseAbs().maxCoeff() < 1e-12 * 60.0);
        }
        REQUIRE(truth.cogging(y).isZero(0.0));
      }
    }
  }
  // The default motor with its parasitics switched off, too.
  MotorParameters motor = fixtures::default_motor();
  switch_off_parasitics(motor.electromagnetics);
  const ElectromagneticTruth truth = make_truth(motor.electromagnetics);
  for (double y = -0.12; y <= 0.12; y += 0.0113) {
    for (int l = 0; l < 3; ++l) {
      const CoilGain expected = classical_gain(classical_of(motor.electromagnetics, l), y, motor.pole_pitch_m());
      REQUIRE((truth.gain(l, y) - expected).cwiseAbs().maxCoeff() < 1e-12 * 60.0);
    }
    REQUIRE(truth.cogging(y).isZero(0.0));
    REQUIRE(truth.direction_dependent(0.1).isZero(0.0));
  }
}

TEST_CASE("5th and 7th field harmonics give a pure 6th-harmonic force ripple under sinusoidal currents",
          "[sim][electromagnetics]") {
  // Σ_p sin(5η_p + ψ)·sin η_p = −(3/2)cos(6η + ψ) and Σ_p sin(7η_p + ψ)·sin η_p
  // = (3/2)cos(6η + ψ): the ripple has only harmonic 6, amplitude between
  // |h5 − h7| and h5 + h7 (the phases ψ are drawn).
  MotorParameters motor = fixtures::ideal_motor(2);
  motor.electromagnetics.fifth_harmonic_relative = 0.03;
  motor.electromagnetics.seventh_harmonic_relative = 0.01;
  const ElectromagneticTruth truth = make_truth(motor.electromagnetics);
  for (int l = 0; l < 2; ++l) {
    const auto ratio = force_ratio_over_pole_pitch(truth, l, 720);
    REQUIRE(std::abs(fourier(ratio, 0) - 1.0) < 1e-12);
    const double ripple = std::abs(fourier(ratio, 6));
    REQUIRE(ripple >= 0.02 - 1e-12);
    REQUIRE(ripple <= 0.04 + 1e-12);
    for (int n = 1; n <= 20; ++n) {
      if (n != 6) REQUIRE(std::abs(fourier(ratio, n)) < 1e-12);
    }
  }
}

TEST_CASE("a per-phase gain mismatch gives a 2nd-harmonic ripple about the mean phase gain", "[sim][electromagnetics]") {
  // Σ_p g_p sin²(η_p) = ½Σ g_p − ½Σ g_p cos(2η_p).
  MotorParameters motor = fixtures::ideal_motor(3);
  motor.electromagnetics.phase_gain_mismatch_rms = 0.02;
  const ElectromagneticTruth truth = make_truth(motor.electromagnetics);
  for (int l = 0; l < 3; ++l) {
    const double mean_gain = (truth.phase_gain(l, 0) + truth.phase_gain(l, 1) + truth.phase_gain(l, 2)) / 3.0;
    const auto ratio = force_ratio_over_pole_pitch(truth, l, 360);
    REQUIRE(std::abs(fourier(ratio, 0) - mean_gain) < 1e-12);
    REQUIRE(std::abs(fourier(ratio, 2)) > 1e-4);
    for (int n = 1; n <= 12; ++n) {
      if (n != 2) REQUIRE(std::abs(fourier(ratio, n)) < 1e-12);
    }
  }
  // Over many seeds the phase gains have mean 1 and the configured spread.
  double sum = 0.0;
  double sum_squares = 0.0;
  int count = 0;
  for (std::uint64_t seed = 1; seed <= 100; ++seed) {
    MotorParameters seeded = fixtures::ideal_motor(4);
    seeded.electromagnetics.phase_gain_mismatch_rms = 0.02;
    seeded.electromagnetics.seed = seed;
    const ElectromagneticTruth drawn = make_truth(seeded.electromagnetics);
    for (int l = 0; l < 4; ++l) {
      for (int p = 0; p < 3; ++p) {
        const double e = drawn.phase_gain(l, p) - 1.0;
        sum += e;
        sum_squares += e * e;
        ++count;
      }
    }
  }
  const double mean = sum / count;
  const double rms = std::sqrt(sum_squares / count - mean * mean);
  REQUIRE(std::abs(mean) < 4.0 * 0.02 / std::sqrt(count));
  REQUIRE(rms == Approx(0.02).epsilon(0.08));
}

TEST_CASE("magnet intensity scales the gain and orientation shifts the electrical angle at y + d^l",
          "[sim][electromagnetics]") {
  MotorParameters motor = fixtures::ideal_motor(3);
  motor.electromagnetics.magnet_intensity = {0.05, 0.02, 0.1};
  const ElectromagneticTruth intensity = make_truth(motor.electromagnetics);
  motor.electromagnetics.magnet_intensity = {};
  motor.electromagnetics.magnet_orientation_rad = {0.05, 0.03, -0.2};
  const ElectromagneticTruth orientation = make_truth(motor.electromagnetics);
  for (double y = -0.1; y <= 0.1; y += 0.0037) {
    for (int l = 0; l < 3; ++l) {
      const double track = y + motor.electromagnetics.coil_sets[static_cast<std::size_t>(l)].lever_arm_m;
      const CoilGain ideal = classical_gain(classical_of(motor.electromagnetics, l), y, motor.pole_pitch_m());
      const CoilGain scaled = (1.0 + intensity.magnet_intensity(track)) * ideal;
      REQUIRE((intensity.gain(l, y) - scaled).cwiseAbs().maxCoeff() < 1e-11);
      const CoilGain shifted = classical_gain(
          classical_of(motor.electromagnetics, l, orientation.magnet_orientation_rad(track)), y, motor.pole_pitch_m());
      REQUIRE((orientation.gain(l, y) - shifted).cwiseAbs().maxCoeff() < 1e-11);
    }
  }
  // The trend is a straight line through zero at the travel centre.
  motor.electromagnetics.magnet_orientation_rad = {0.0, 0.03, 0.4};
  const ElectromagneticTruth trend = make_truth(motor.electromagnetics);
  REQUIRE(trend.magnet_orientation_rad(0.0) == Approx(0.0).margin(1e-15));
  REQUIRE(trend.magnet_orientation_rad(0.1) - trend.magnet_orientation_rad(-0.05) == Approx(0.4 * 0.15));
}

TEST_CASE("smooth random track functions have the configured RMS and correlation length", "[sim][electromagnetics]") {
  const double rms = 0.03;
  const double correlation_length = 0.01;
  double mean_square = 0.0;
  double lagged_product = 0.0;
  double near_product = 0.0;
  int count = 0;
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    MotorParameters motor = fixtures::ideal_motor(1);
    motor.electromagnetics.magnet_intensity = {rms, correlation_length, 0.0};
    motor.electromagnetics.seed = seed;
    const ElectromagneticTruth truth = make_truth(motor.electromagnetics);
    for (double u = -0.1; u <= 0.1; u += 0.0005) {
      const double a = truth.magnet_intensity(u);
      mean_square += a * a;
      near_product += a * truth.magnet_intensity(u + 0.1 * correlation_length);
      lagged_product += a * truth.magnet_intensity(u + 4.0 * correlation_length);
      ++count;
    }
  }
  mean_square /= count;
  REQUIRE(std::sqrt(mean_square) == Approx(rms).epsilon(0.1));
  // Strongly correlated within a tenth of the correlation length, nearly
  // independent beyond the B-spline support (four knot intervals).
  REQUIRE(near_product / count / mean_square > 0.9);
  REQUIRE(std::abs(lagged_product / count / mean_square) < 0.1);
}

TEST_CASE("smooth random functions are cubic B-splines as clm::UniformCubicBasis evaluates them",
          "[sim][electromagnetics]") {
  const SmoothRandomFunction scalar({0.05, 0.013, 0.2}, -0.1, 0.14, 17);
  const SmoothRandomFunction triple(Wrench(1.0, 0.0, 0.3), 0.02, -0.1, 0.14, 18);
  for (const auto* function : {&scalar, &triple}) {
    const UniformCubicBasis& basis = function->basis();
    REQUIRE(basis.spacing_m() <= (function == &scalar ? 0.013 : 0.02));
    REQUIRE(basis.start_m <= -0.1);
    REQUIRE(basis.end_m >= 0.14);
  }
  const double centre = 0.5 * (-0.1 + 0.14);
  for (double u = -0.2; u <= 0.25; u += 0.00037) {
    const auto span = scalar.basis().evaluate(u);
    double expected = 0.2 * (u - centre);
    for (int k = 0; k < 4; ++k) expected += span.value[k] * scalar.coefficient(0, span.first + k);
    REQUIRE(scalar(u) == Approx(expected).margin(1e-13));
    REQUIRE(scalar.wrench(u) == Wrench(scalar(u), 0.0, 0.0));
    const auto triple_span = triple.basis().evaluate(u);
    Wrench expected_triple = Wrench::Zero();
    for (int k = 0; k < 4; ++k) {
      for (int c = 0; c < 3; ++c) expected_triple[c] += triple_span.value[k] * triple.coefficient(c, triple_span.first + k);
    }
    REQUIRE((triple.wrench(u) - expected_triple).cwiseAbs().maxCoeff() < 1e-13);
    REQUIRE(triple.wrench(u).y() == 0.0);  // zero RMS: zero coefficients
  }
  REQUIRE(SmoothRandomFunction()(0.1) == 0.0);
}

TEST_CASE("cogging: periodic part over the pole pitch, slow part, cable spring", "[sim][electromagnetics]") {
  MotorParameters motor = fixtures::ideal_motor(3);
  auto& em = motor.electromagnetics;
  em.cogging_periodic = {{1, {3.0, 0.4, 0.2}}, {2, {1.0, 0.2, 0.1}}, {6, {0.5, 0.0, 0.05}}};
  const ElectromagneticTruth periodic = make_truth(em);
  const int samples = 600;
  Wrench mean_square = Wrench::Zero();
  for (int k = 0; k < samples; ++k) {
    const double y = -0.05 + em.pole_pitch_m * k / samples;
    const Wrench f = periodic.cogging(y);
    REQUIRE((periodic.cogging(y + em.pole_pitch_m) - f).cwiseAbs().maxCoeff() < 1e-12);
    REQUIRE((periodic.cogging(y + 3.0 * em.pole_pitch_m) - f).cwiseAbs().maxCoeff() < 1e-11);
    mean_square += f.cwiseProduct(f) / samples;
  }
  // Parseval: Σ A²/2 per axis.
  REQUIRE(mean_square.x() == Approx((9.0 + 1.0 + 0.25) / 2.0).epsilon(1e-12));
  REQUIRE(mean_square.y() == Approx((0.16 + 0.04) / 2.0).epsilon(1e-12));
  REQUIRE(mean_square.z() == Approx((0.04 + 0.01 + 0.0025) / 2.0).epsilon(1e-12));

  em.cogging_periodic.clear();
  em.cogging_spring_rate_N_N_Nm_per_m = {20.0, -2.0, 1.0};
  em.cogging_spring_neutral_m = 0.01;
  const ElectromagneticTruth spring = make_truth(em);
  for (double y : {-0.1, -0.02, 0.01, 0.07}) {
    REQUIRE((spring.cogging(y) + Wrench(20.0, -2.0, 1.0) * (y - 0.01)).cwiseAbs().maxCoeff() < 1e-14);
  }

  em.cogging_spring_rate_N_N_Nm_per_m.setZero();
  em.cogging_slow_rms_N_N_Nm = {2.0, 0.0, 0.5};
  em.cogging_slow_correlation_length_m = 0.02;
  Wrench slow_mean_square = Wrench::Zero();
  int count = 0;
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    em.seed = seed;
    const ElectromagneticTruth slow = make_truth(em);
    for (double y = -0.1; y <= 0.1; y += 0.001) {
      const Wrench f = slow.cogging(y);
      slow_mean_square += f.cwiseProduct(f);
      ++count;
    }
  }
  slow_mean_square /= count;
  REQUIRE(std::sqrt(slow_mean_square.x()) == Approx(2.0).epsilon(0.1));
  REQUIRE(slow_mean_square.y() == 0.0);
  REQUIRE(std::sqrt(slow_mean_square.z()) == Approx(0.5).epsilon(0.1));
}

TEST_CASE("the wrench is linear in the currents plus cogging and the direction-dependent term",
          "[sim][electromagnetics]") {
  const MotorParameters motor = fixtures::default_motor();
  const ElectromagneticTruth truth = make_truth(motor.electromagnetics);
  const auto& em = motor.electromagnetics;
  for (double v : {-0.2, -0.001, 0.0, 0.0005, 0.1}) {
    const Wrench expected = em.direction_dependent_N_N_Nm * std::tanh(v / em.direction_smoothing_velocity_m_per_s);
    REQUIRE((truth.direction_dependent(v) - expected).cwiseAbs().maxCoeff() < 1e-15);
  }
  REQUIRE((truth.direction_dependent(0.05) + truth.direction_dependent(-0.05)).isZero(1e-15));
  CurrentVector i1(6), i2(6);
  i1 << 1.0, -0.5, 2.0, 0.3, -1.2, 0.7;
  i2 << -0.4, 0.9, 0.1, -2.0, 0.5, 0.5;
  for (double y = -0.1; y <= 0.1; y += 0.013) {
    const double v = 0.03;
    Wrench by_parts = truth.cogging(y) + truth.direction_dependent(v);
    for (int l = 0; l < 3; ++l) by_parts += truth.gain(l, y) * (1.5 * i1 - i2).segment<2>(2 * l);
    const CurrentVector combined = 1.5 * i1 - i2;
    REQUIRE((truth.wrench(y, v, combined) - by_parts).cwiseAbs().maxCoeff() < 1e-11);
    StackedGain stacked;
    truth.stacked_gain(y, stacked);
    REQUIRE(stacked.cols() == 6);
    REQUIRE((stacked * combined + truth.cogging(y) + truth.direction_dependent(v) - truth.wrench(y, v, combined))
                .cwiseAbs()
                .maxCoeff() < 1e-11);
  }
}

TEST_CASE("each parasitic draws from its own stream and the seed decides everything", "[sim][electromagnetics]") {
  MotorParameters motor = fixtures::default_motor();
  const ElectromagneticTruth reference = make_truth(motor.electromagnetics);
  const ElectromagneticTruth again = make_truth(motor.electromagnetics);
  MotorParameters no_cogging = motor;
  no_cogging.electromagnetics.cogging_periodic.clear();
  no_cogging.electromagnetics.cogging_slow_rms_N_N_Nm.setZero();
  const ElectromagneticTruth without_cogging = make_truth(no_cogging.electromagnetics);
  MotorParameters reseeded = motor;
  reseeded.electromagnetics.seed = motor.electromagnetics.seed + 1;
  const ElectromagneticTruth other_seed = make_truth(reseeded.electromagnetics);
  bool differs = false;
  for (double y = -0.12; y <= 0.12; y += 0.0071) {
    for (int l = 0; l < 3; ++l) {
      REQUIRE(reference.gain(l, y) == again.gain(l, y));
      REQUIRE(reference.gain(l, y) == without_cogging.gain(l, y));
      differs = differs || reference.gain(l, y) != other_seed.gain(l, y);
    }
    REQUIRE(reference.cogging(y) == again.cogging(y));
  }
  REQUIRE(differs);
}

TEST_CASE("invalid truth parameters are refused with the parameter's name", "[sim][electromagnetics]") {
  MotorParameters motor = fixtures::ideal_motor(2);
  auto em = motor.electromagnetics;
  em.coil_sets[1].motor_constant_N_per_A = -1.0;
  REQUIRE_THROWS_WITH(make_truth(em), Catch::Contains("coil_sets[1].motor_constant_N_per_A"));
  em = motor.electromagnetics;
  em.coil_sets.clear();
  REQUIRE_THROWS_WITH(make_truth(em), Catch::Contains("coil_sets"));
  em = motor.electromagnetics;
  em.magnet_intensity.correlation_length_m = 0.0;
  REQUIRE_THROWS_WITH(make_truth(em), Catch::Contains("magnet_intensity.correlation_length_m"));
  em = motor.electromagnetics;
  em.cogging_periodic = {{0, {1.0, 0.0, 0.0}}};
  REQUIRE_THROWS_WITH(make_truth(em), Catch::Contains("cogging_periodic[0].order"));
}
