// Algorithm 1 with the corrected update (docs/commutation.md §2) and the offset-robust
// variant, on synthetic data generated from eq. (16).
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <vector>

#include "commutation/calibration.hpp"
#include "commutation/transform.hpp"

using namespace clm;

namespace {

constexpr double kDriveK = 67.0;
constexpr double kDriveZeta = -0.52;

struct SyntheticGroup {
  double delta_rad;
  std::vector<double> position_m, magnitude_N, force_N;
  CalibrationGroup view() const { return {delta_rad, position_m, magnitude_N, force_N}; }
};

double cogging_N(double y) { return 3.0 * std::sin(kTwoPi * y / 0.016) + 1.5 * std::cos(kTwoPi * y / 0.032) + 20.0 * y; }

// A closed-loop-like experiment: back-and-forth motion, command = inertia +
// friction, and (when `loop_rejects_cogging`) the loop also pushes against the
// cogging, which correlates the command with the offset force.
SyntheticGroup make_group(double k_true, double zeta_true, double delta, double noise_N, bool with_cogging,
                          bool loop_rejects_cogging, std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, noise_N);
  SyntheticGroup group{delta, {}, {}, {}};
  const double c = k_true / kDriveK * std::cos(zeta_true - kDriveZeta - delta);
  const int n = 26000;
  for (int t = 0; t < n; ++t) {
    const double time = t * 1e-3;
    const double y = 0.1 * std::sin(0.6 * time) * std::cos(0.05 * time);
    const double velocity = 0.06 * std::cos(0.6 * time);
    const double acceleration = -0.036 * std::sin(0.6 * time);
    double command = 20.0 * acceleration + 40.0 * std::tanh(velocity / 0.002) + 100.0 * velocity;
    const double offset = with_cogging ? cogging_N(y) : 0.0;
    if (loop_rejects_cogging) command -= offset / c;
    group.position_m.push_back(y);
    group.magnitude_N.push_back(command);
    group.force_N.push_back(c * command + offset + noise(rng));
  }
  return group;
}

}  // namespace

TEST_CASE("Algorithm 1 is exact on noise-free data for any offset pair", "[calibration]") {
  std::mt19937_64 rng(1);
  for (double delta : {kPi / 4, kPi / 6}) {
    for (auto [k, zeta] : {std::pair{61.34, -0.54}, std::pair{55.0, -0.2}, std::pair{70.0, -1.1}}) {
      const auto first = make_group(k, zeta, -delta, 0.0, false, false, rng);
      const auto second = make_group(k, zeta, +delta, 0.0, false, false, rng);
      const auto result = calibrate_classical(kDriveK, kDriveZeta, first.view(), second.view());
      CHECK(result.motor_constant_N_per_A == Approx(k).epsilon(1e-10));
      CHECK(result.phase_offset_rad == Approx(zeta).margin(1e-10));
      CHECK(result.residual_rms_N[0] < 1e-9);
    }
  }
  // Two arbitrary distinct offsets, not symmetric about zero.
  const auto first = make_group(61.0, -0.6, 0.1, 0.0, false, false, rng);
  const auto second = make_group(61.0, -0.6, 0.9, 0.0, false, false, rng);
  const auto result = calibrate_classical(kDriveK, kDriveZeta, first.view(), second.view());
  CHECK(result.motor_constant_N_per_A == Approx(61.0).epsilon(1e-10));
  CHECK(result.phase_offset_rad == Approx(-0.6).margin(1e-10));
}

TEST_CASE("the printed update (15) without / sin 2Δ is wrong for Δ = π/6", "[calibration]") {
  // Independent check of the correction: evaluate the printed formula by hand.
  const double k = 61.0, zeta = -0.6, delta = kPi / 6;
  const double c1 = k / kDriveK * std::cos(zeta - (kDriveZeta - delta));
  const double c2 = k / kDriveK * std::cos(zeta - (kDriveZeta + delta));
  const double printed = (kDriveZeta - delta) + std::atan(c2 / c1 - std::cos(2 * delta));
  double k_hat = 0.0, zeta_hat = 0.0;
  calibration_update(kDriveK, kDriveZeta, -delta, c1, delta, c2, k_hat, zeta_hat);
  CHECK(zeta_hat == Approx(zeta).margin(1e-12));
  CHECK(std::abs(printed - zeta) > 0.01);
}

TEST_CASE("Algorithm 1 with sensor noise stays within 0.5 % and 0.005 rad", "[calibration]") {
  std::mt19937_64 rng(2);
  for (double delta : {kPi / 4, kPi / 6}) {
    const auto first = make_group(61.34, -0.54, -delta, 2.0, false, false, rng);
    const auto second = make_group(61.34, -0.54, +delta, 2.0, false, false, rng);
    const auto result = calibrate_classical(kDriveK, kDriveZeta, first.view(), second.view());
    CHECK(std::abs(result.motor_constant_N_per_A / 61.34 - 1.0) < 0.005);
    CHECK(std::abs(result.phase_offset_rad + 0.54) < 0.005);
    CHECK(result.residual_rms_N[0] == Approx(2.0).epsilon(0.05));
  }
}

TEST_CASE("equal offsets are refused with a reason", "[calibration]") {
  std::mt19937_64 rng(3);
  const auto first = make_group(61.0, -0.5, 0.3, 0.0, false, false, rng);
  const auto second = make_group(61.0, -0.5, 0.3, 0.0, false, false, rng);
  CHECK_THROWS_AS(calibrate_classical(kDriveK, kDriveZeta, first.view(), second.view()), CalibrationError);
  const auto shifted = make_group(61.0, -0.5, 0.3 + kPi, 0.0, false, false, rng);
  CHECK_THROWS_AS(calibrate_classical(kDriveK, kDriveZeta, first.view(), shifted.view()), CalibrationError);
}

TEST_CASE("cogging rejected by the loop biases Algorithm 1; the offset-robust fit is not biased", "[calibration]") {
  std::mt19937_64 rng(4);
  const double k = 61.34, zeta = -0.54, delta = kPi / 4;
  const auto first = make_group(k, zeta, -delta, 0.5, true, true, rng);
  const auto second = make_group(k, zeta, +delta, 0.5, true, true, rng);
  const auto plain = calibrate_classical(kDriveK, kDriveZeta, first.view(), second.view());
  const UniformCubicBasis basis{-0.11, 0.11, 110};
  const auto robust = calibrate_classical_offset_robust(kDriveK, kDriveZeta, first.view(), second.view(), basis);
  INFO("plain k = " << plain.motor_constant_N_per_A << " robust k = " << robust.motor_constant_N_per_A);
  CHECK(std::abs(plain.motor_constant_N_per_A / k - 1.0) > 0.005);
  CHECK(std::abs(robust.motor_constant_N_per_A / k - 1.0) < 0.001);
  CHECK(std::abs(robust.phase_offset_rad - zeta) < 0.005);
  CHECK(robust.residual_rms_N[0] < plain.residual_rms_N[0]);
}
