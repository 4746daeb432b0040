// Γ, T, T⁻¹ of eq. (19)-(21) and (39), with the sign conventions of docs/commutation.md §4.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "commutation/classical.hpp"
#include "commutation/transform.hpp"

using namespace clm;
using Catch::Matchers::WithinAbs;

TEST_CASE("Gamma times its closed-form inverse is the identity", "[transform]") {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> position(-1.0, 1.0);
  const DriveCommutation drive{67.0, -0.52};
  for (int trial = 0; trial < 1000; ++trial) {
    const double y = position(rng);
    const Eigen::Matrix2d product = gamma_matrix(drive, y, 0.032) * gamma_inverse(drive, y, 0.032);
    REQUIRE((product - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("Gamma times T reproduces the drive's law (19)", "[transform]") {
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> position(-0.2, 0.2);
  std::uniform_real_distribution<double> magnitude(-100.0, 100.0);
  std::uniform_real_distribution<double> delta(-kPi, kPi);
  const DriveCommutation drive{67.0, -0.52};
  for (int trial = 0; trial < 1000; ++trial) {
    const double y = position(rng);
    const DriveSetpoint setpoint{magnitude(rng), delta(rng)};
    const Eigen::Vector2d via_gamma = gamma_matrix(drive, y, 0.032) * transform_forward(setpoint);
    REQUIRE((via_gamma - drive_phase_currents(drive, setpoint, y, 0.032)).norm() < 1e-12);
  }
}

TEST_CASE("T(T^-1(v)) = v for every v, zero and sign changes included", "[transform]") {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> component(-50.0, 50.0);
  std::vector<Eigen::Vector2d> cases = {{0.0, 0.0}, {1.0, 0.0}, {-1.0, 0.0}, {0.0, 1.0}, {0.0, -1.0},
                                        {-3.0, 4.0}, {-3.0, -4.0}, {3.0, -4.0}, {1e-300, -1e-300}};
  for (int i = 0; i < 10000; ++i) cases.emplace_back(component(rng), component(rng));
  for (auto convention : {PhaseConvention::kSignedMagnitude, PhaseConvention::kNonNegativeMagnitude}) {
    for (const auto& v : cases) {
      const DriveSetpoint s = transform_inverse(v, convention);
      REQUIRE((transform_forward(s) - v).norm() <= 1e-12 * std::max(1.0, v.norm()));
      if (convention == PhaseConvention::kSignedMagnitude) {
        REQUIRE(s.delta_rad > -kPi / 2);
        REQUIRE(s.delta_rad <= kPi / 2);
      } else {
        REQUIRE(s.magnitude_N >= 0.0);
      }
    }
  }
}

TEST_CASE("signed magnitude keeps the phase continuous through a force sign change", "[transform]") {
  // F_1 = f, F_2 = 0.2·f: as f passes through zero, Δ stays atan(0.2).
  for (double f : {-10.0, -1e-6, 1e-6, 10.0}) {
    const DriveSetpoint s = transform_inverse({f, 0.2 * f}, PhaseConvention::kSignedMagnitude);
    CHECK_THAT(s.delta_rad, WithinAbs(std::atan(0.2), 1e-12));
    CHECK(std::signbit(s.magnitude_N) == std::signbit(f));
    const DriveSetpoint n = transform_inverse({f, 0.2 * f}, PhaseConvention::kNonNegativeMagnitude);
    CHECK_THAT(std::abs(n.delta_rad), WithinAbs(f > 0 ? std::atan(0.2) : kPi - std::atan(0.2), 1e-12));
  }
}

TEST_CASE("setpoint from currents makes the drive apply those currents (39)", "[transform]") {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> position(-0.2, 0.2);
  std::uniform_real_distribution<double> current(-5.0, 5.0);
  const DriveCommutation drive{67.0, -0.52};
  for (auto convention : {PhaseConvention::kSignedMagnitude, PhaseConvention::kNonNegativeMagnitude}) {
    for (int trial = 0; trial < 2000; ++trial) {
      const double y = position(rng);
      const Eigen::Vector2d i(current(rng), current(rng));
      const DriveSetpoint s = setpoint_from_currents(drive, y, 0.032, i, convention);
      REQUIRE((drive_phase_currents(drive, s, y, 0.032) - i).norm() < 1e-12);
    }
  }
}
