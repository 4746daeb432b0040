// Classical model (7), classical commutation (12) with the corrected share, and
// the force it produces on a mis-calibrated motor, eq. (16).
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "commutation/classical.hpp"
#include "commutation/transform.hpp"

using namespace clm;
using Catch::Matchers::WithinAbs;

TEST_CASE("classical gain matches eq. (7) worked by hand at zero angle", "[classical]") {
  // k = 3/2 makes the prefactor 2/3·k = 1; η = 0.
  const ClassicalCoilSet coil_set{1.5, 0.0, 0.5, 0.1};
  const CoilGain k = classical_gain(coil_set, 0.0, 0.03);
  const double r = std::sqrt(3.0) / 2.0;
  // Row y: [sin 0, sin 2π/3, sin −2π/3] = [0, r, −r]; reduced columns a−c, b−c.
  CHECK_THAT(k(0, 0), WithinAbs(r, 1e-15));
  CHECK_THAT(k(0, 1), WithinAbs(2 * r, 1e-15));
  // Row x: μ·[1, −1/2, −1/2] -> [0.5·1.5, 0].
  CHECK_THAT(k(1, 0), WithinAbs(0.75, 1e-15));
  CHECK_THAT(k(1, 1), WithinAbs(0.0, 1e-15));
  // Row z = d·row x.
  CHECK_THAT(k(2, 0), WithinAbs(0.075, 1e-15));
  CHECK_THAT(k(2, 1), WithinAbs(0.0, 1e-15));
}

TEST_CASE("A cos + B sin reproduces the classical gain at every position", "[classical]") {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> position(-0.2, 0.2);
  const ClassicalCoilSet coil_set{61.3, -0.54, 0.12, 0.04};
  CoilGain a, b;
  classical_physics_parameters(coil_set, a, b);
  for (int trial = 0; trial < 1000; ++trial) {
    const double y = position(rng);
    const double theta = electrical_angle_rad(y, 0.032);
    const CoilGain expected = classical_gain(coil_set, y, 0.032);
    const CoilGain actual = a * std::cos(theta) + b * std::sin(theta);
    REQUIRE((expected - actual).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("force share is (k^l)^2 / sum (k^m)^2 and equal constants split evenly", "[classical]") {
  const ClassicalEstimate estimates[2] = {{60.0, 0.0}, {80.0, 0.0}};
  double share[2];
  classical_force_share(estimates, 100.0, share);
  CHECK_THAT(share[0], WithinAbs(36.0, 1e-12));
  CHECK_THAT(share[1], WithinAbs(64.0, 1e-12));
  const ClassicalEstimate equal[3] = {{67.0, 0.1}, {67.0, 0.2}, {67.0, 0.3}};
  double even[3];
  classical_force_share(equal, 90.0, even);
  for (double s : even) CHECK_THAT(s, WithinAbs(30.0, 1e-12));
}

TEST_CASE("classical currents of eq. (12) worked by hand", "[classical]") {
  const ClassicalEstimate estimates[2] = {{60.0, kPi / 2}, {80.0, kPi / 2}};
  CurrentVector currents;
  classical_currents(estimates, 0.03, 0.0, 100.0, currents);
  REQUIRE(currents.size() == 4);
  // η̂ = π/2: i_a = sin(π/2)·36/60, i_b = sin(7π/6)·36/60.
  CHECK_THAT(currents[0], WithinAbs(0.6, 1e-12));
  CHECK_THAT(currents[1], WithinAbs(-0.3, 1e-12));
  CHECK_THAT(currents[2], WithinAbs(0.8, 1e-12));
  CHECK_THAT(currents[3], WithinAbs(-0.4, 1e-12));
}

TEST_CASE("classical commutation on a mis-calibrated motor produces the wrench of eq. (16)", "[classical]") {
  const ClassicalCoilSet truth{60.1, -0.55, 0.13, 0.05};
  const DriveCommutation drive{67.0, -0.52};
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> position(-0.1, 0.1);
  std::uniform_real_distribution<double> force(-200.0, 200.0);
  for (int trial = 0; trial < 200; ++trial) {
    const double y = position(rng);
    const double f = force(rng);
    const Eigen::Vector2d i = drive_phase_currents(drive, {f, 0.0}, y, 0.032);
    const Eigen::Vector3d wrench = classical_gain(truth, y, 0.032) * i;
    const double ratio = truth.motor_constant_N_per_A / drive.motor_constant_N_per_A;
    const double angle = truth.phase_offset_rad - drive.phase_offset_rad;
    // Eq. (16) with the x-orientation of eq. (7): the sine rows carry ζ̂ − ζ.
    REQUIRE_THAT(wrench[0], WithinAbs(ratio * std::cos(angle) * f, 1e-9));
    REQUIRE_THAT(wrench[1], WithinAbs(ratio * truth.orthogonal_ratio * std::sin(-angle) * f, 1e-9));
    REQUIRE_THAT(wrench[2],
                 WithinAbs(ratio * truth.lever_arm_m * truth.orthogonal_ratio * std::sin(-angle) * f, 1e-9));
  }
}

TEST_CASE("classical setpoints make the drive apply the classical currents", "[classical]") {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> position(-0.1, 0.1);
  std::uniform_real_distribution<double> force(-300.0, 300.0);
  const ClassicalEstimate estimates[3] = {{61.34, -0.54}, {61.62, -0.55}, {60.07, -0.55}};
  const DriveCommutation drive{67.0, -0.52};
  for (auto convention : {PhaseConvention::kSignedMagnitude, PhaseConvention::kNonNegativeMagnitude}) {
    for (int trial = 0; trial < 200; ++trial) {
      const double y = position(rng);
      const double f = force(rng);
      CurrentVector currents;
      classical_currents(estimates, 0.032, y, f, currents);
      DriveSetpoint setpoints[3];
      classical_setpoints(estimates, drive, f, convention, setpoints);
      for (int l = 0; l < 3; ++l) {
        const Eigen::Vector2d applied = drive_phase_currents(drive, setpoints[l], y, 0.032);
        REQUIRE((applied - currents.segment<2>(2 * l)).norm() < 1e-12);
      }
    }
  }
}
