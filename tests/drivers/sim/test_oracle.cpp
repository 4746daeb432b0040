// The oracle commutation inverts the static truth exactly: what is left of
// the commutation error is the direction-dependent force. (In closed loop on
// the daemon's cycle: tests/tools/test_commission_runs.cpp.)
#include <catch2/catch.hpp>
#include <array>
#include <cmath>

#include "commutation/classical.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/oracle.hpp"
#include "drivers/sim/random.hpp"
#include "drivers/sim/sim_support.hpp"
#include "support/allocation_counter.hpp"

using namespace clm;
using namespace clm::sim;

namespace {

/// A motor of `coil_sets` coil sets with every parasitic switched on.
MotorParameters parasitic_motor(int coil_sets) {
  MotorParameters motor = fixtures::ideal_motor(coil_sets);
  auto& em = motor.electromagnetics;
  em.phase_gain_mismatch_rms = 0.02;
  em.magnet_intensity = {0.03, 0.015, 0.1};
  em.magnet_orientation_rad = {0.03, 0.02, -0.1};
  em.fifth_harmonic_relative = 0.03;
  em.seventh_harmonic_relative = 0.01;
  em.cogging_periodic = {{1, {4.0, 0.3, 0.2}}, {2, {1.5, 0.1, 0.1}}};
  em.cogging_slow_rms_N_N_Nm = {2.0, 0.2, 0.2};
  em.cogging_spring_rate_N_N_Nm_per_m = {20.0, 1.0, 0.5};
  em.direction_dependent_N_N_Nm = {-1.5, 0.2, 0.1};
  for (auto& set : em.coil_sets) set.driving_force_lever_arm_m = 0.003;
  return motor;
}

}  // namespace

TEST_CASE("the oracle's wrench error is exactly the direction-dependent term (L = 2..4)", "[sim][oracle]") {
  RandomStream random(5);
  for (int coil_sets = 2; coil_sets <= 4; ++coil_sets) {
    const MotorParameters parameters = parasitic_motor(coil_sets);
    const SimulatedMotor motor(parameters);
    const OracleCommutator oracle(motor.electromagnetics(), parameters.drive.commutation);
    REQUIRE(oracle.coil_sets() == coil_sets);
    CommutationOutput out;
    for (int trial = 0; trial < 300; ++trial) {
      const double y = -0.1 + 0.2 * random.uniform();
      const double v = 0.3 * (random.uniform() - 0.5);
      const Wrench desired(400.0 * (random.uniform() - 0.5), 20.0 * (random.uniform() - 0.5),
                           2.0 * (random.uniform() - 0.5));
      oracle.commutate(y, desired, out);
      REQUIRE_FALSE(out.damping_engaged);
      const Wrench direct = motor.electromagnetics().wrench(y, v, out.currents_A);
      REQUIRE((direct - desired - motor.direction_dependent(v)).norm() < 1e-9 * (1.0 + desired.norm()));
      // The same through the drive: setpoints → the drive's fixed law → currents.
      CurrentVector through_drive(2 * coil_sets);
      for (int l = 0; l < coil_sets; ++l) {
        through_drive.segment<2>(2 * l) = drive_phase_currents(
            parameters.drive.commutation, out.setpoints[static_cast<std::size_t>(l)], y, parameters.pole_pitch_m());
      }
      const Wrench driven = motor.electromagnetics().wrench(y, v, through_drive);
      REQUIRE((driven - desired - motor.direction_dependent(v)).norm() < 1e-9 * (1.0 + desired.norm()));
    }
  }
}

TEST_CASE("for L = 1 the oracle gives the least-squares wrench of the static truth", "[sim][oracle]") {
  const MotorParameters parameters = parasitic_motor(1);
  const SimulatedMotor motor(parameters);
  const OracleCommutator oracle(motor.electromagnetics(), parameters.drive.commutation);
  CommutationOutput out;
  for (double y = -0.1; y <= 0.1; y += 0.0173) {
    const Wrench desired(50.0, 3.0, -0.5);
    oracle.commutate(y, desired, out);
    const CoilGain gain = motor.true_gain(0, y);
    const Wrench residual = motor.electromagnetics().wrench(y, 0.0, out.currents_A) - desired;
    // Normal equations: the residual is orthogonal to both columns of K.
    REQUIRE((gain.transpose() * residual).norm() < 1e-9 * gain.norm() * desired.norm());
  }
}
