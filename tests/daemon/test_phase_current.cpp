// clm-servod with a phase-current drive (config/servod-phase-current.yaml,
// drive.profile phase_current): the cycle sends the law's currents as they
// are, the record shows them, the simulated drive applies them, and the axis
// tracks Fig. 8 as with the magnitude/phase drive. The law's currents are
// recomputed here with an independent ModelCommutator, and the reference
// from the program file.
#include <catch2/catch.hpp>
#include <cmath>

#include "commutation/commutator.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/servod/program_file.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "drivers/sim/motor.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::CommutationMode;

namespace {

constexpr const char* kPhaseCurrentConfig = "config/servod-phase-current.yaml";

/// Fig. 8 as the ideal plant's copy of `config` holds it.
servo::Command fig8(const char* config = kPhaseCurrentConfig) {
  servo::Command run;
  run.kind = Kind::kRunProgram;
  run.program.assign(test::ideal_plant_program("fig8.yaml", config));
  return run;
}

}  // namespace

TEST_CASE("the phase-current configuration gives the protocol and the simulated drive profile phase_current",
          "[daemon][phase_current]") {
  const auto config = test::ideal_plant_config(kPhaseCurrentConfig);
  CHECK(config.motor.drive_profile == DriveProfile::kPhaseCurrent);
  CHECK(config.servo.protocol.drive_profile == DriveProfile::kPhaseCurrent);
  servod::WiredAxis axis(config);
  CHECK(axis.simulated_motor()->parameters().drive.profile == DriveProfile::kPhaseCurrent);
  // The default stays magnitude_phase.
  CHECK(test::virtual_config().servo.protocol.drive_profile == DriveProfile::kMagnitudePhase);
}

TEST_CASE("with phase_current every cycle sends the PGNN law's currents, which the drive applies",
          "[daemon][phase_current]") {
  test::TemporaryDirectory dir("clm-daemon-phase-current");
  const auto files = test::write_truth_laws(dir, test::source_path("config/motor-sim-phase-current.yaml"));
  const auto config = test::with_laws(test::ideal_plant_config(kPhaseCurrentConfig), files, CommutationMode::kPgnn);
  servod::WiredAxis axis(config);
  servod::ServoDaemon& daemon = axis.daemon;
  const ModelFile model = load_model_file(files.pgnn);
  const ModelCommutator law(model.model, config.motor.drive, config.commutation.options);
  CommutationOutput expected;
  expected.currents_A.resize(2 * config.motor.coil_sets);

  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 10);
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  REQUIRE(daemon.submit(fig8()).accepted());
  int driving_cycles = 0;
  double largest_current_A = 0.0;
  for (int k = 0; k < 3000; ++k) {
    daemon.run_cycles(1);
    REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
    const auto& record = daemon.cycle().record();
    const auto sent = test::sent_setpoints(axis);
    REQUIRE(sent.complete);
    REQUIRE(sent.command.enable);
    law.commutate(record.y_m, Wrench(record.Fy_star_N, record.Fx_star_N, record.Tz_star_Nm), expected);
    const auto& truth = axis.simulated_motor()->truth();
    for (int l = 0; l < config.motor.coil_sets; ++l) {
      const auto s = static_cast<std::size_t>(l);
      INFO("cycle " << record.cycle << " coil set " << l + 1);
      // On the bus: the law's currents within half an LSB (1 mA).
      const double tolerance_A = 0.5 * can::kCurrentLsb_A + 1e-12;
      REQUIRE(std::abs(sent.command.currents[s].ia_A - expected.currents_A[2 * l]) <= tolerance_A);
      REQUIRE(std::abs(sent.command.currents[s].ib_A - expected.currents_A[2 * l + 1]) <= tolerance_A);
      // The record shows the law's currents.
      REQUIRE(std::abs(record.ia_A[s] - expected.currents_A[2 * l]) <= 1e-9);
      REQUIRE(std::abs(record.ib_A[s] - expected.currents_A[2 * l + 1]) <= 1e-9);
      // The drive applies exactly what it decoded (below its current limit).
      REQUIRE(truth.currents_A[2 * l] == sent.command.currents[s].ia_A);
      REQUIRE(truth.currents_A[2 * l + 1] == sent.command.currents[s].ib_A);
      // The magnitude/phase fields of the frames are not there: nothing was decoded into them.
      REQUIRE(sent.command.setpoints[s].magnitude_N == 0.0);
      largest_current_A = std::max(largest_current_A, std::abs(sent.command.currents[s].ia_A));
    }
    if (std::abs(record.F_star_N) > 1.0) ++driving_cycles;
  }
  CHECK(driving_cycles > 1000);
  CHECK(largest_current_A > 0.1);
}

TEST_CASE("with phase_current the experiments send the drive's nominal law through one coil set",
          "[daemon][phase_current]") {
  const auto config = test::ideal_plant_config(kPhaseCurrentConfig);
  servod::WiredAxis axis(config);
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(10);
  test::submit_experiment(daemon, 2, kPi / 4);
  test::command(daemon, Kind::kEnable, 10);
  REQUIRE(daemon.submit(fig8()).accepted());
  for (int k = 0; k < 2000; ++k) {
    daemon.run_cycles(1);
    REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
    const auto& record = daemon.cycle().record();
    const auto sent = test::sent_setpoints(axis);
    REQUIRE(sent.complete);
    // Eq. (18)/(19) at the measured position, computed here.
    const Eigen::Vector2d i = drive_phase_currents(config.motor.drive, {record.F_star_N, kPi / 4}, record.y_m,
                                                   config.motor.pole_pitch_m);
    for (int l = 0; l < config.motor.coil_sets; ++l) {
      const auto s = static_cast<std::size_t>(l);
      const double ia = l == 1 ? i.x() : 0.0, ib = l == 1 ? i.y() : 0.0;
      REQUIRE(std::abs(sent.command.currents[s].ia_A - ia) <= 0.5e-3 + 1e-12);
      REQUIRE(std::abs(sent.command.currents[s].ib_A - ib) <= 0.5e-3 + 1e-12);
    }
  }
}

TEST_CASE("with phase_current the axis tracks Fig. 8 with the PGNN law as closely as with magnitude/phase",
          "[daemon][phase_current][tracking]") {
  test::TemporaryDirectory dir("clm-daemon-phase-current-tracking");
  const auto files = test::write_truth_laws(dir, test::source_path("config/motor-sim.yaml"));
  double rms_m[2] = {0.0, 0.0};
  const char* configs[2] = {"config/servod.yaml", kPhaseCurrentConfig};
  for (int c = 0; c < 2; ++c) {
    INFO(configs[c]);
    const auto config = test::with_laws(test::ideal_plant_config(configs[c]), files, CommutationMode::kPgnn);
    servod::WiredAxis axis(config);
    servod::ServoDaemon& daemon = axis.daemon;
    daemon.run_cycles(10);
    test::command(daemon, Kind::kEnable, 10);
    const control::MoveProgram expected = servod::program_from(
        servod::load_program_file(test::ideal_plant_program("fig8.yaml", configs[c])), daemon.cycle().mailbox().hold_position_m());
    REQUIRE(daemon.submit(fig8(configs[c])).accepted());
    double sum_sq = 0.0;
    std::int64_t cycles = 0;
    for (double t_s = 0.0; t_s <= expected.duration_s(); t_s = static_cast<double>(cycles) * config.servo.period_s) {
      daemon.run_cycles(1);
      REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
      const double error_m = expected.sample(t_s).position_m - axis.simulated_motor()->truth().position_m;
      sum_sq += error_m * error_m;
      ++cycles;
    }
    rms_m[c] = std::sqrt(sum_sq / static_cast<double>(cycles));
  }
  INFO("rms error magnitude_phase " << rms_m[0] << " m, phase_current " << rms_m[1] << " m");
  CHECK(rms_m[1] < 1e-4);
  // Holding the currents over the period instead of re-commutating at every
  // substep costs little at the Fig. 8 speeds (≤ 0.15 m/s: ≤ 5° electrical per period).
  CHECK(rms_m[1] < 1.5 * rms_m[0]);
}
