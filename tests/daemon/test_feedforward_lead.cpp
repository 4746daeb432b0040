// The feedforward taken from the reference the drive's lag ahead
// (ServoSettings::force_lag_s, docs/servod.md, "The feedforward's lead"): on
// a drive whose force comes a delay after its setpoint, the axis tracks as
// on a drive without one, and worse when the daemon is not told the delay.
// The simulator's own law and mechanics, so nothing but the delay differs.
#include <catch2/catch.hpp>

#include <cmath>

#include "daemon/servod/axis_wiring.hpp"
#include "daemon/servod/program_file.hpp"
#include "drivers/sim/motor_file.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::CommutationMode;

namespace {

/// Mean square of the tracking error (reference − measured position, on the
/// ideal plant's encoder) [m²] over moves at the motion limits (10 m/s²,
/// 2000 m/s³: the feedforward changes by m·j, 30 kN/s), with the simulator's own spline law and its own mass and
/// friction as the feedforward; the drive's setpoint delay `actual_s`, the
/// daemon told `told_s`.
double tracking_mse_m2(double actual_s, double told_s) {
  test::TemporaryDirectory dir("clm-feedforward-lead");
  const std::string motor_file = test::ideal_plant_file("motor-sim.yaml");
  const auto files = test::write_truth_laws(dir, motor_file);
  servod::ServodConfig config = test::with_laws(test::ideal_plant_config(), files, CommutationMode::kSpline);
  sim::MotorParameters parameters = sim::load_motor_parameters(motor_file);
  parameters.drive.setpoint_delay_s = actual_s;
  config.motor.setpoint_delay_s = config.servo.setpoint_delay_s = told_s;
  const auto& mechanics = parameters.mechanics;
  config.servo.feedforward = {mechanics.translator_mass_kg, mechanics.viscous_friction_N_s_per_m,
                              mechanics.coulomb_friction_N};
  servod::WiredAxis axis(config, servod::wire_simulated_axis(config, parameters));
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 10);
  REQUIRE(daemon.cycle().status().mode == CommutationMode::kSpline);
  const std::string program = dir.path() + "/moves.yaml";
  test::write_text(program,
                   "format: clm-servo-program\nformat_version: 1\ndescription: moves at the motion limits\n"
                   "start_m: 0.0\nsteps:\n"
                   "  - {target_m: 0.08, velocity_m_per_s: 0.5, acceleration_m_per_s2: 10.0, jerk_m_per_s3: 2000.0, dwell_s: 0.05}\n"
                   "  - {target_m: -0.08, velocity_m_per_s: 0.5, acceleration_m_per_s2: 10.0, jerk_m_per_s3: 2000.0, dwell_s: 0.05}\n"
                   "  - {target_m: 0.0, velocity_m_per_s: 0.5, acceleration_m_per_s2: 10.0, jerk_m_per_s3: 2000.0, dwell_s: 0.05}\n");
  REQUIRE(daemon.submit_program(servod::load_program_file(program)).accepted());
  daemon.run_cycles(1);
  double sum_m2 = 0.0;
  long count = 0;
  while (daemon.cycle().record().program_running) {
    daemon.run_cycles(1);
    const double error_m = daemon.cycle().record().e_m;
    sum_m2 += error_m * error_m;
    ++count;
  }
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  REQUIRE(count > 500);
  return sum_m2 / static_cast<double>(count);
}

}  // namespace

TEST_CASE("The feedforward leads by the drive's delay, so its force arrives on time", "[daemon][feedforward]") {
  // A delay τ makes the feedforward's force late by τ, an error of about
  // τ·m·j (15 N at 0.5 ms) while the reference's acceleration changes,
  // which the feedback must take up; sampled τ ahead, the force arrives
  // when the reference asks for it. What the lead cannot remove is the
  // feedback's own delay, which it acts on the error with: on 2026-11-28
  // the told axis tracked 1.8× the undelayed one, the untold 36× the told.
  const double ideal_m2 = tracking_mse_m2(0.0, 0.0);
  const double told_m2 = tracking_mse_m2(5e-4, 5e-4);
  const double untold_m2 = tracking_mse_m2(5e-4, 0.0);
  INFO("tracking MSE: " << ideal_m2 << " m² on a drive without delay; with a 0.5 ms delay " << told_m2
                        << " m² told, " << untold_m2 << " m² not told");
  CHECK(untold_m2 > 10.0 * told_m2);  // the lead removes the feedforward's late force
  CHECK(told_m2 < 2.5 * ideal_m2);    // and what is left is the feedback's delay
}
