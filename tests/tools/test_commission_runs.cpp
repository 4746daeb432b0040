// The commissioning's in-process runs are the daemon's servo cycle on the
// simulated motor (commission::run_program on a servod::WiredAxis, virtual
// clock): what a recorded cycle holds and how it pairs with the plant,
// experiment mode, the oracle in closed loop, and the refusals. The
// expectations come from the simulator's truth and the CAN signals'
// resolution, not from the daemon's record.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "commutation/classical.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/servod/axis_wiring.hpp"
#include "drivers/can/can_protocol.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/sim_support.hpp"
#include "tests/daemon/daemon_support.hpp"
#include "tools/commission/runs.hpp"

using namespace clm;
using namespace clm::sim;

namespace {

/// The simulator's truth at every cycle the commissioning records: the
/// Recorder hands each recorded cycle on to this observer, so truth[k]
/// belongs to samples[k] of the recording.
class TruthAtEachCycle final : public servod::CycleObserver {
 public:
  explicit TruthAtEachCycle(const SimulatedMotor& motor) : motor_(motor) { truth.reserve(40000); }
  void on_cycle(const servo::ServoCycle&, const servod::LoopTiming&) noexcept override {
    truth.push_back(motor_.truth());  // test only: reserved above
  }
  std::vector<TruthState> truth;

 private:
  const SimulatedMotor& motor_;
};

/// A setpoint as the drive decodes it from its frame (rounded to the LSBs).
DriveSetpoint as_sent(double magnitude_N, double delta_rad) {
  return {can::kMagnitudeLsb_N * std::round(magnitude_N / can::kMagnitudeLsb_N),
          can::kDeltaLsb_rad * std::round(delta_rad / can::kDeltaLsb_rad)};
}

/// The phase currents the drive applies at `position_m` for the setpoints a
/// cycle recorded, as the frames carried them.
CurrentVector drive_currents(const MotorParameters& parameters, const servo::CycleRecord& cycle, double position_m) {
  CurrentVector currents(2 * cycle.coil_sets);
  for (int l = 0; l < cycle.coil_sets; ++l) {
    const auto s = static_cast<std::size_t>(l);
    currents.segment<2>(2 * l) = drive_phase_currents(
        parameters.drive.commutation, as_sent(cycle.magnitude_N[s], cycle.setpoint_delta_rad[s]), position_m,
        parameters.pole_pitch_m());
  }
  return currents;
}

servod::ProgramFile program_file(const control::MoveProgram& program) { return {program.start_m(), program.steps()}; }

struct Run {
  commission::Recording recording;
  std::vector<TruthState> truth;
};

/// Enables the axis, selects `mode` (experiment: coil set `coil_set`, 1-based, at `delta_rad`) and runs `program`.
Run run_on_daemon(servod::WiredAxis& axis, const control::MoveProgram& program, servo::CommandKind mode_command,
                  servo::CommutationMode mode, int coil_set = 0, double delta_rad = 0.0) {
  servo::Command command;
  if (axis.daemon.cycle().status().state != servo::ServoState::kEnabled) {
    command.kind = servo::CommandKind::kEnable;
    commission::execute(axis.daemon, command);
  }
  command = {};
  command.kind = mode_command;
  command.commutation = mode;
  command.coil_set = coil_set;
  command.delta_rad = delta_rad;
  commission::execute(axis.daemon, command);
  TruthAtEachCycle observer(*axis.simulated_motor());
  Run run;
  run.recording = commission::run_program(axis, program_file(program), "test", &observer);
  run.truth = std::move(observer.truth);
  REQUIRE(run.truth.size() == run.recording.samples.size());
  return run;
}

}  // namespace

TEST_CASE("a commissioning run records the daemon's cycles: each measured force is the previous cycle's setpoints "
          "at the true position",
          "[commission][runs]") {
  const servod::ServodConfig config = test::ideal_plant_config("config/servod.yaml");
  MotorParameters parameters = load_motor_parameters(config.motor_file);
  fixtures::ideal_sensors(parameters);
  // Without the direction-dependent force the wrench depends on the position
  // and the currents alone, which the test recomputes.
  parameters.electromagnetics.direction_dependent_N_N_Nm.setZero();
  servod::WiredAxis axis(config, servod::wire_simulated_axis(config, parameters));
  const SimulatedMotor& motor = *axis.simulated_motor();
  const control::MoveProgram program = fixtures::stroke_program(parameters, 0.15);
  const Run run = run_on_daemon(axis, program, servo::CommandKind::kSetCommutation, servo::CommutationMode::kOriginal);
  const auto& samples = run.recording.samples;
  const double period_s = config.servo.period_s;
  // Every cycle of the program, one after the other.
  REQUIRE(samples.size() >= static_cast<std::size_t>(program.duration_s() / period_s));
  REQUIRE(run.recording.y_true_m.size() == samples.size());
  REQUIRE(samples[0].program_time_s <= period_s);

  double max_tracking_error_m = 0.0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const servo::CycleRecord& s = samples[k];
    const TruthState& truth = run.truth[k];
    REQUIRE(s.state == servo::ServoState::kEnabled);
    REQUIRE(s.commutation == servo::CommutationMode::kOriginal);
    REQUIRE(s.program_time_s == Approx(samples[0].program_time_s + static_cast<double>(k) * period_s).margin(1e-9));
    REQUIRE(s.r_m == Approx(program.sample(s.program_time_s).position_m).margin(1e-9));
    REQUIRE(run.recording.y_true_m[k] == truth.position_m);
    // The ideal encoder through the drive's frame (1 nm).
    REQUIRE(std::abs(s.y_m - truth.position_m) <= 0.5 * can::kPositionLsb_m + 1e-15);
    // The plant already drives this cycle's setpoints, as the frames carried them.
    const CurrentVector own = drive_currents(parameters, s, truth.position_m);
    REQUIRE((truth.currents_A - own).cwiseAbs().maxCoeff() < 1e-9);
    max_tracking_error_m = std::max(max_tracking_error_m, std::abs(s.r_m - s.y_m));
    if (k == 0) continue;
    REQUIRE(s.cycle == samples[k - 1].cycle + 1);
    // The force sensor's frame of this cycle was made by the previous
    // cycle's setpoints over the period before, at this cycle's position
    // (docs/commissioning.md, "Experiment data"), to the frame's resolution.
    const Wrench expected = motor.electromagnetics().wrench(
        truth.position_m, truth.velocity_m_per_s, drive_currents(parameters, samples[k - 1], truth.position_m));
    REQUIRE(s.force_measured);
    REQUIRE(std::abs(s.Fy_N - expected.x()) <= 0.5 * can::kForceYLsb_N + 1e-9);
    REQUIRE(std::abs(s.Fx_N - expected.y()) <= 0.5 * can::kForceXLsb_N + 1e-9);
    REQUIRE(std::abs(s.Tz_Nm - expected.z()) <= 0.5 * can::kTorqueZLsb_Nm + 1e-9);
  }
  // 40 Hz feedback without feedforward keeps the translator within 0.5 mm
  // and brings it to the end of the program.
  CHECK(max_tracking_error_m < 5e-4);
  CHECK(std::abs(samples.back().y_m - program.end_m()) < 5e-5);
}

TEST_CASE("in experiment mode the daemon's cycle drives one coil set alone with magnitude F* and a constant offset",
          "[commission][runs]") {
  for (const bool two_coil : {false, true}) {
    const servod::ServodConfig config = test::ideal_plant_config(two_coil ? "config/servod-2coil.yaml" : "config/servod.yaml");
    const MotorParameters parameters = load_motor_parameters(config.motor_file);
    servod::WiredAxis axis(config);
    const int coil_sets = config.motor.coil_sets;
    REQUIRE(coil_sets == (two_coil ? 2 : 3));
    const control::MoveProgram program = fixtures::stroke_program(parameters, 0.15);
    for (int l = 0; l < coil_sets; ++l) {
      const double delta_rad = l % 2 == 0 ? kPi / 4.0 : -kPi / 4.0;
      const Run run = run_on_daemon(axis, program, servo::CommandKind::kSetExperiment,
                                    servo::CommutationMode::kExperiment, l + 1, delta_rad);
      double sum_squares = 0.0;
      for (std::size_t k = 0; k < run.recording.samples.size(); ++k) {
        const servo::CycleRecord& s = run.recording.samples[k];
        REQUIRE(s.commutation == servo::CommutationMode::kExperiment);
        REQUIRE(s.coil_set == l + 1);  // 1-based, as the CSV column
        REQUIRE(s.delta_rad == delta_rad);
        REQUIRE(s.Fy_star_N == s.F_star_N);
        for (int m = 0; m < coil_sets; ++m) {
          const auto sm = static_cast<std::size_t>(m);
          if (m == l) {
            REQUIRE(s.magnitude_N[sm] == s.F_star_N);
            REQUIRE(s.setpoint_delta_rad[sm] == delta_rad);
          } else {
            REQUIRE(s.magnitude_N[sm] == 0.0);
            // The other coil sets carry no current in the plant.
            REQUIRE(run.truth[k].currents_A.segment<2>(2 * m).cwiseAbs().maxCoeff() == 0.0);
          }
        }
        sum_squares += (s.r_m - s.y_m) * (s.r_m - s.y_m);
      }
      // The loop holds the reference with one coil set at Δ = ±π/4.
      CHECK(std::sqrt(sum_squares / static_cast<double>(run.recording.samples.size())) < 1e-4);
    }
  }
}

TEST_CASE("on the daemon's cycle the oracle's commutation error is the direction-dependent force",
          "[commission][runs][oracle]") {
  for (const bool two_coil : {false, true}) {
    const servod::ServodConfig config = test::ideal_plant_config(two_coil ? "config/servod-2coil.yaml" : "config/servod.yaml");
    MotorParameters parameters = load_motor_parameters(config.motor_file);
    fixtures::ideal_sensors(parameters);
    servod::WiredAxis axis(config, servod::wire_simulated_axis(config, parameters));
    const SimulatedMotor& motor = *axis.simulated_motor();
    const control::MoveProgram program = fixtures::stroke_program(parameters, 0.15);
    const Run run = run_on_daemon(axis, program, servo::CommandKind::kSetCommutation, servo::CommutationMode::kOracle);
    const auto& samples = run.recording.samples;
    // The static wrench the drive produces at position y for a cycle's setpoints.
    const auto static_wrench = [&](double y, const servo::CycleRecord& cycle) {
      return Wrench(motor.electromagnetics().wrench(y, 0.0, drive_currents(parameters, cycle, y)));
    };
    // What the setpoint frames' resolution allows the static inverse to miss
    // by: half an LSB of magnitude and of offset per coil set, through the
    // largest motor constant.
    double largest_constant_N_per_A = 0.0;
    for (const auto& set : parameters.electromagnetics.coil_sets) {
      largest_constant_N_per_A = std::max(largest_constant_N_per_A, set.motor_constant_N_per_A);
    }
    const double gain = 1.5 * largest_constant_N_per_A / parameters.drive.commutation.motor_constant_N_per_A;
    double error_power = 0.0, remainder_power = 0.0;
    for (std::size_t k = 1; k < samples.size(); ++k) {
      const servo::CycleRecord& previous = samples[k - 1];
      const servo::CycleRecord& s = samples[k];
      const Wrench desired(previous.Fy_star_N, previous.Fx_star_N, previous.Tz_star_Nm);
      double magnitudes_N = 0.0;
      for (int l = 0; l < previous.coil_sets; ++l) magnitudes_N += std::abs(previous.magnitude_N[static_cast<std::size_t>(l)]);
      const double resolution = gain * (previous.coil_sets * 0.5 * can::kMagnitudeLsb_N + magnitudes_N * 0.5 * can::kDeltaLsb_rad) +
                                1e-9 * (1.0 + desired.norm());
      // The force of the previous cycle's demand made over the period, as
      // the translator moved on (the drive re-commutates from the true
      // position): the static wrench at the period's start plus this motion term.
      const Wrench motion_term = static_wrench(run.truth[k].position_m, previous) -
                                 static_wrench(run.truth[k - 1].position_m, previous);
      // The oracle inverted the static truth at the position it measured
      // (the ideal encoder), so Recording::true_wrench, the wrench over the
      // period, is F* plus half the motion term (the mean along a near-linear
      // stretch), to second order in the motion and to the substeps' grid
      // (their start positions: 1/(2n) of the motion, n ≥ 10).
      const Wrench over_period = desired + 0.5 * motion_term;
      REQUIRE((run.recording.true_wrench[k - 1] - over_period).cwiseAbs().maxCoeff() <
              resolution + 0.15 * motion_term.cwiseAbs().maxCoeff());
      // Measured − F*: that force at the period's end, plus the direction-dependent force.
      const Wrench measured(s.Fy_N, s.Fx_N, s.Tz_Nm);
      const Wrench error = measured - desired;
      const Wrench remainder = error - motor.direction_dependent(run.truth[k].velocity_m_per_s);
      REQUIRE((remainder - motion_term).cwiseAbs().maxCoeff() < resolution + can::kForceXLsb_N);
      error_power += error.x() * error.x();
      remainder_power += remainder.x() * remainder.x();
    }
    error_power /= static_cast<double>(samples.size() - 1);
    remainder_power /= static_cast<double>(samples.size() - 1);
    const double c = parameters.electromagnetics.direction_dependent_N_N_Nm.x();
    // The error is about C² (the translator moves most of the time); the
    // motion within a period and the frames' resolution add a few percent at most.
    INFO("error " << error_power << " N², remainder " << remainder_power << " N²");
    CHECK(error_power > 0.3 * c * c);
    CHECK(remainder_power < 0.05 * error_power);
  }
}

TEST_CASE("the daemon's cycle refuses an experiment on a coil set the motor does not have", "[commission][runs]") {
  const servod::ServodConfig config = test::ideal_plant_config("config/servod-2coil.yaml");
  commission::InProcessRunner runner(config);
  runner.enable();
  CHECK_THROWS_WITH(runner.set_experiment(3, 0.0), Catch::Contains("refused"));
  CHECK_THROWS_WITH(runner.set_experiment(0, 0.0), Catch::Contains("refused"));
  runner.set_experiment(2, 0.0);  // the last one it has
}
