// The daemon runs the paper's Fig. 8 program with each commutation and the
// axis tracks it. The reference is recomputed here from the program file and
// compared with the simulator's true position, not with the daemon's record.
#include <catch2/catch.hpp>
#include <cmath>

#include "daemon/control/trajectory.hpp"
#include "daemon/servod/program_file.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/motor_file.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::CommutationMode;

namespace {

struct Tracking {
  std::int64_t cycles = 0;
  double max_error_m = 0.0;
  double rms_error_m = 0.0;
  double final_position_m = 0.0;
};

/// Runs Fig. 8 from the hold position; `r` is sampled from an independent
/// MoveProgram planned from the same file and hold position.
Tracking run_fig8(servod::WiredAxis& axis) {
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 10);
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  const std::string path = test::absolute_encoder_file("programs/fig8.yaml");
  const control::MoveProgram expected = servod::program_from(servod::load_program_file(path), daemon.cycle().mailbox().hold_position_m());
  servo::Command run;
  run.kind = Kind::kRunProgram;
  run.program.assign(path);
  REQUIRE(daemon.submit(run).accepted());
  const double period_s = daemon.config().servo.period_s;
  Tracking result;
  double sum_sq = 0.0;
  while (true) {
    daemon.run_cycles(1);
    REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
    const double t_s = static_cast<double>(result.cycles) * period_s;
    if (t_s > expected.duration_s()) break;
    const double r_m = expected.sample(t_s).position_m;
    REQUIRE(daemon.cycle().record().r_m == Approx(r_m).margin(1e-12));
    const double error_m = r_m - axis.simulated_motor()->truth().position_m;
    result.max_error_m = std::max(result.max_error_m, std::abs(error_m));
    sum_sq += error_m * error_m;
    ++result.cycles;
  }
  CHECK_FALSE(daemon.cycle().record().program_running);
  daemon.run_cycles(500);  // settle at the end
  result.rms_error_m = std::sqrt(sum_sq / static_cast<double>(result.cycles));
  result.final_position_m = axis.simulated_motor()->truth().position_m;
  return result;
}

}  // namespace

TEST_CASE("the daemon runs the Fig. 8 program in every commutation mode and tracks it", "[daemon][tracking]") {
  test::TemporaryDirectory dir("clm-daemon-tracking");
  const auto files = test::write_truth_laws(dir, test::source_path("config/motor-sim.yaml"));
  const auto mode = GENERATE(CommutationMode::kOriginal, CommutationMode::kClassical, CommutationMode::kPgnn,
                             CommutationMode::kSpline, CommutationMode::kOracle);
  const auto config = test::config_with_laws(files, mode);
  // Bound on |r − y|. Without feedforward (servod.yaml) the feedback alone
  // supplies the force of the motion: m·a_max for the translator, Coulomb
  // and viscous friction at v_max (the slow cable force is taken up by the
  // integrator). Against k_p that force is the quasi-static lag; the 45°
  // phase margin and the commutation's force ripple add at most half again.
  const auto motor = sim::load_motor_parameters(config.motor_file);
  const double a_max_m_per_s2 = 1.0, v_max_m_per_s = 0.15;  // fig8.yaml
  const double motion_force_N = motor.mechanics.translator_mass_kg * a_max_m_per_s2 +
                                motor.mechanics.coulomb_friction_N +
                                motor.mechanics.viscous_friction_N_s_per_m * v_max_m_per_s;
  const double max_error_m = 1.5 * motion_force_N / config.servo.pid.proportional_N_per_m;  // ≈ 0.1 mm
  servod::WiredAxis axis(config);
  servod::ServoDaemon& daemon = axis.daemon;
  REQUIRE(daemon.cycle().status().mode == mode);
  const Tracking tracking = run_fig8(axis);
  INFO(servo::name(mode) << ": " << tracking.cycles << " cycles, max |r - y| " << tracking.max_error_m << " m, rms "
                         << tracking.rms_error_m << " m, end at " << tracking.final_position_m << " m; bound " << max_error_m << " m");
  CHECK(tracking.cycles > 25000);  // the whole program: six moves of 0.2 m and the approach
  CHECK(tracking.max_error_m < max_error_m);
  CHECK(std::abs(tracking.final_position_m - (-0.1)) < 10e-6);
  CHECK(daemon.cycle().status().counters.frames_missing == 0);
}

TEST_CASE("without a force sensor the axis tracks Fig. 8 with the PGNN law exactly as with one, nothing waits for "
          "force frames and an experiment runs without forces",
          "[daemon][tracking][force_sensor]") {
  test::TemporaryDirectory dir("clm-daemon-no-sensor");
  const auto files = test::write_truth_laws(dir, test::source_path("config/motor-sim.yaml"));
  auto with_sensor = test::config_with_laws(files, CommutationMode::kPgnn);
  REQUIRE(can::has_force_sensor(with_sensor.servo.protocol));
  auto without = with_sensor;
  without.servo.protocol.force_sensor_node_id = can::kNoForceSensor;

  servod::WiredAxis sensed(with_sensor);
  const Tracking reference = run_fig8(sensed);
  servod::WiredAxis bare(without);
  const Tracking tracking = run_fig8(bare);
  INFO("rms |r - y| " << reference.rms_error_m << " m with the sensor, " << tracking.rms_error_m << " m without");
  // The loop never uses the sensor: the same motion to the last bit.
  CHECK(tracking.cycles == reference.cycles);
  CHECK(tracking.rms_error_m == reference.rms_error_m);
  CHECK(tracking.max_error_m == reference.max_error_m);
  const auto& counters = bare.daemon.cycle().status().counters;
  CHECK(counters.frames_missing == 0);
  CHECK(counters.force_sensor_losses == 0);
  CHECK(bare.daemon.cycle().status().force_sensor_warning == servo::Fault::kNone);
  CHECK_FALSE(bare.daemon.cycle().record().force_measured);
  CHECK(sensed.daemon.cycle().record().force_measured);
  // Per cycle the bus carries SYNC, one feedback frame and the setpoints.
  CHECK(counters.frames_received == counters.cycles);

  // An experiment (for the identification from positions) runs, and its
  // records say they measured no force.
  servo::Command experiment;
  experiment.kind = servo::CommandKind::kSetExperiment;
  experiment.coil_set = 2;
  experiment.delta_rad = 0.5;
  (void)bare.daemon.take_replies();
  REQUIRE(bare.daemon.submit(experiment).accepted());
  bare.daemon.run_cycles(2);
  const auto replies = bare.daemon.take_replies();
  REQUIRE(replies.size() == 1);
  CHECK(replies[0].accepted());
  CHECK(bare.daemon.cycle().status().mode == CommutationMode::kExperiment);
  CHECK_FALSE(bare.daemon.cycle().record().force_measured);
}
