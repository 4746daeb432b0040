// The simulated motor: mechanics against analytic and independently
// integrated expectations, the drive's current limit, watchdog, end stops and
// status word, the sensors, determinism and the allocation-free cycle.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <vector>

#include "commutation/classical.hpp"
#include "commutation/commutator.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/random.hpp"
#include "drivers/sim/sim_support.hpp"
#include "support/allocation_counter.hpp"

using namespace clm;
using namespace clm::sim;

namespace {

constexpr double kPeriod = 1e-3;

std::vector<ClassicalEstimate> true_estimates(const MotorParameters& motor) {
  std::vector<ClassicalEstimate> estimates;
  for (const auto& set : motor.electromagnetics.coil_sets) {
    estimates.push_back({set.motor_constant_N_per_A, set.phase_offset_rad});
  }
  return estimates;
}

double peak_phase_current(const Eigen::Vector2d& i) {
  return std::max({std::abs(i.x()), std::abs(i.y()), std::abs(i.x() + i.y())});
}

}  // namespace

TEST_CASE("without parasitics classical commutation with the true k and zeta is exact, also in motion",
          "[sim][motor]") {
  for (int coil_sets = 1; coil_sets <= 4; ++coil_sets) {
    MotorParameters parameters = fixtures::ideal_motor(coil_sets);
    SimulatedMotor motor(parameters);
    const auto estimates = true_estimates(parameters);
    const ClassicalCommutator law(estimates, parameters.pole_pitch_m(), parameters.drive.commutation);
    CommutationOutput out;
    motor.reset(0.0);
    double max_error = 0.0;
    double max_speed = 0.0;
    for (int k = 0; k < 2000; ++k) {
      const double t = k * kPeriod;
      // Zero-mean velocity: the translator oscillates by about ±16 mm.
      const double force = 30.0 * std::cos(kTwoPi * 2.0 * t);
      const SensorFrame before = motor.sense();
      law.commutate(before.position_m, Wrench(force, 0.0, 0.0), out);
      REQUIRE(motor.command(std::span<const DriveSetpoint>(out.setpoints.data(), static_cast<std::size_t>(coil_sets)),
                            true) == CommandResult::kAccepted);
      REQUIRE(motor.step(kPeriod) == StepResult::kOk);
      // The drive re-commutates at every substep from the true position, so
      // the wrench is exact at the end of the period although the translator
      // moved during it.
      const SensorFrame after = motor.sense();
      max_error = std::max(max_error, (after.wrench - Wrench(force, 0.0, 0.0)).cwiseAbs().maxCoeff());
      max_speed = std::max(max_speed, std::abs(motor.truth().velocity_m_per_s));
    }
    REQUIRE(max_error < 1e-9);
    REQUIRE(max_speed > 0.1);  // it did move: 30 N/(m·4π rad/s) ≈ 0.2 m/s
    REQUIRE(motor.status().enabled());
    REQUIRE_FALSE(motor.status().fault());
  }
}

TEST_CASE("with no force the translator decays by viscous friction as v0·exp(−b·t/m)", "[sim][motor][mechanics]") {
  MotorParameters parameters = fixtures::ideal_motor(3);
  parameters.mechanics.viscous_friction_N_s_per_m = 30.0;
  SimulatedMotor motor(parameters);
  const double m = parameters.mechanics.translator_mass_kg;
  const double b = 30.0;
  const double v0 = 0.2;
  motor.reset(-0.05, v0);
  for (int k = 1; k <= 800; ++k) {
    motor.step(kPeriod);
    const double t = k * kPeriod;
    const TruthState truth = motor.truth();
    const double v = v0 * std::exp(-b * t / m);
    const double y = -0.05 + v0 * m / b * (1.0 - std::exp(-b * t / m));
    // Semi-implicit Euler: the velocity's global error is of order h·b/m
    // relative; the position runs ahead by at most one substep of travel h·v0.
    REQUIRE(truth.velocity_m_per_s == Approx(v).epsilon(2e-4));
    REQUIRE(truth.position_m == Approx(y).margin(parameters.mechanics.integration_step_s * v0));
    REQUIRE(truth.friction_N == Approx(b * truth.velocity_m_per_s));
    REQUIRE(truth.wrench.isZero(0.0));  // nothing electromagnetic
  }
}

TEST_CASE("with Coulomb and viscous friction the translator stops where the ODE says", "[sim][motor][mechanics]") {
  MotorParameters parameters = fixtures::ideal_motor(2);
  parameters.mechanics.viscous_friction_N_s_per_m = 25.0;
  parameters.mechanics.coulomb_friction_N = 10.0;
  parameters.mechanics.friction_smoothing_velocity_m_per_s = 2e-4;
  SimulatedMotor motor(parameters);
  const double m = parameters.mechanics.translator_mass_kg;
  const double b = 25.0;
  const double fc = 10.0;
  const double vs = 2e-4;
  const double v0 = 0.15;
  motor.reset(0.0, v0);

  // Independent expectation 1: the same ODE m·v' = −b·v − F_c·tanh(v/v_s)
  // integrated with classical RK4 at a 1 µs step.
  double y_ode = 0.0;
  double v_ode = v0;
  const auto acceleration = [&](double v) { return -(b * v + fc * std::tanh(v / vs)) / m; };
  for (int k = 1; k <= 600; ++k) {
    for (int s = 0; s < 1000; ++s) {
      const double h = 1e-6;
      const double k1v = acceleration(v_ode), k1y = v_ode;
      const double k2v = acceleration(v_ode + 0.5 * h * k1v), k2y = v_ode + 0.5 * h * k1v;
      const double k3v = acceleration(v_ode + 0.5 * h * k2v), k3y = v_ode + 0.5 * h * k2v;
      const double k4v = acceleration(v_ode + h * k3v), k4y = v_ode + h * k3v;
      v_ode += h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
      y_ode += h / 6.0 * (k1y + 2 * k2y + 2 * k3y + k4y);
    }
    motor.step(kPeriod);
    const TruthState truth = motor.truth();
    REQUIRE(truth.velocity_m_per_s == Approx(v_ode).margin(1e-5));
    // Semi-implicit Euler: at most one substep of travel h·v0 apart.
    REQUIRE(truth.position_m == Approx(y_ode).margin(parameters.mechanics.integration_step_s * v0));
  }

  // Independent expectation 2: with sign() friction the translator stops at
  // t_stop = (m/b)·ln(1 + b·v0/F_c), after (m/b)·(v0 − (F_c/b)·ln(1 + b·v0/F_c)).
  const double t_stop = m / b * std::log(1.0 + b * v0 / fc);
  const double y_stop = m / b * (v0 - fc / b * std::log(1.0 + b * v0 / fc));
  REQUIRE(t_stop < 0.5);
  REQUIRE(motor.truth().position_m == Approx(y_stop).margin(2e-5));
  REQUIRE(std::abs(motor.truth().velocity_m_per_s) < 1e-6);
}

TEST_CASE("the current limit scales a coil set's currents to the limit and sets the status bit", "[sim][motor][drive]") {
  MotorParameters parameters = fixtures::ideal_motor(2);
  parameters.drive.phase_current_limit_A = 5.0;
  SimulatedMotor motor(parameters);
  const DriveCommutation& drive = parameters.drive.commutation;
  const double pole_pitch = parameters.pole_pitch_m();
  // 10 A amplitude asked of coil set 1, 1 A of coil set 2.
  const DriveSetpoint setpoints[2] = {{10.0 * drive.motor_constant_N_per_A, 0.3}, {1.0 * drive.motor_constant_N_per_A, -0.2}};
  motor.reset(0.0123);
  REQUIRE(motor.command(setpoints, true) == CommandResult::kAccepted);
  motor.step(kPeriod);
  const TruthState truth = motor.truth();
  const Eigen::Vector2d unlimited = drive_phase_currents(drive, setpoints[0], truth.position_m, pole_pitch);
  const Eigen::Vector2d applied = truth.currents_A.segment<2>(0);
  REQUIRE(peak_phase_current(unlimited) > 5.0);
  REQUIRE(peak_phase_current(applied) == Approx(5.0).epsilon(1e-12));
  // Same direction (electrical angle kept): applied = unlimited·5/peak.
  REQUIRE((applied - unlimited * (5.0 / peak_phase_current(unlimited))).norm() < 1e-12);
  // The other coil set is below the limit and untouched.
  REQUIRE((truth.currents_A.segment<2>(2) - drive_phase_currents(drive, setpoints[1], truth.position_m, pole_pitch))
              .norm() < 1e-12);
  REQUIRE(motor.status().current_limited());
  REQUIRE(motor.status().enabled());
  REQUIRE_FALSE(motor.status().fault());
  REQUIRE(truth.current_limited_substeps == motor.substeps(kPeriod));

  // Not latched: the next step within the limit clears it.
  const DriveSetpoint small[2] = {{20.0, 0.0}, {20.0, 0.0}};
  motor.command(small, true);
  motor.step(kPeriod);
  REQUIRE_FALSE(motor.status().current_limited());
  REQUIRE(motor.status().enabled());
}

TEST_CASE("the watchdog stops the current after the timeout and latches until clear_fault", "[sim][motor][drive]") {
  MotorParameters parameters = fixtures::ideal_motor(3);
  parameters.drive.watchdog_timeout_s = 4.5e-3;
  SimulatedMotor motor(parameters);
  const DriveSetpoint setpoints[3] = {{10.0, 0.0}, {10.0, 0.0}, {10.0, 0.0}};

  // Fresh setpoints every period keep the drive running.
  for (int k = 0; k < 100; ++k) {
    motor.command(setpoints, true);
    motor.step(kPeriod);
  }
  REQUIRE(motor.status().enabled());
  REQUIRE_FALSE(motor.status().watchdog());

  // One command, then periods of 0.5 ms: the current flows up to 4.5 ms.
  motor.command(setpoints, true);
  for (int k = 1; k <= 8; ++k) {
    motor.step(0.5e-3);
    REQUIRE(motor.status().enabled());
    REQUIRE(motor.truth().currents_A.norm() > 0.0);
  }
  motor.step(0.5e-3);  // 4.5 ms after the command
  DriveStatus status = motor.status();
  REQUIRE(status.watchdog());
  REQUIRE(status.fault());
  REQUIRE_FALSE(status.enabled());
  REQUIRE(motor.truth().currents_A.isZero(0.0));

  // Latched: new commands do not restart the current.
  motor.command(setpoints, true);
  motor.step(kPeriod);
  REQUIRE(motor.status().watchdog());
  REQUIRE(motor.truth().currents_A.isZero(0.0));

  // clear_fault: no fault, but disabled until the next enable command.
  motor.clear_fault();
  status = motor.status();
  REQUIRE_FALSE(status.fault());
  REQUIRE_FALSE(status.watchdog());
  REQUIRE_FALSE(status.enabled());
  motor.step(kPeriod);
  REQUIRE(motor.truth().currents_A.isZero(0.0));
  motor.command(setpoints, true);
  REQUIRE(motor.status().enabled());
  REQUIRE(motor.truth().currents_A.norm() > 0.0);
}

TEST_CASE("enable = false stops the current without a fault and disarms the watchdog", "[sim][motor][drive]") {
  SimulatedMotor motor(fixtures::ideal_motor(2));
  const DriveSetpoint setpoints[2] = {{10.0, 0.1}, {10.0, 0.1}};
  motor.command(setpoints, true);
  REQUIRE(motor.truth().currents_A.norm() > 0.0);
  motor.command(setpoints, false);
  REQUIRE(motor.truth().currents_A.isZero(0.0));
  for (int k = 0; k < 20; ++k) motor.step(kPeriod);
  REQUIRE(motor.status().word == 0u);
}

TEST_CASE("invalid setpoints are rejected and latch a fault", "[sim][motor][drive]") {
  SimulatedMotor motor(fixtures::ideal_motor(3));
  const DriveSetpoint two[2] = {{1.0, 0.0}, {1.0, 0.0}};
  REQUIRE(motor.command(two, true) == CommandResult::kWrongCoilSetCount);
  REQUIRE(motor.status().invalid_setpoint());
  REQUIRE(motor.status().fault());
  motor.clear_fault();
  const DriveSetpoint not_finite[3] = {{1.0, 0.0}, {std::nan(""), 0.0}, {1.0, 0.0}};
  REQUIRE(motor.command(not_finite, true) == CommandResult::kNotFinite);
  REQUIRE(motor.status().invalid_setpoint());
  REQUIRE(motor.truth().currents_A.isZero(0.0));
  REQUIRE(motor.step(0.0) == StepResult::kInvalidPeriod);
  REQUIRE(motor.step(std::nan("")) == StepResult::kInvalidPeriod);
  REQUIRE(motor.step(1e9) == StepResult::kInvalidPeriod);
  REQUIRE(motor.truth().time_s == 0.0);
}

TEST_CASE("end stops stop the translator dead, report the collision and fault the drive", "[sim][motor][mechanics]") {
  MotorParameters parameters = fixtures::ideal_motor(2);
  SimulatedMotor motor(parameters);
  const double k_hat = parameters.drive.commutation.motor_constant_N_per_A;
  const auto estimates = true_estimates(parameters);
  const ClassicalCommutator law(estimates, parameters.pole_pitch_m(), parameters.drive.commutation);
  const double force = 24.0;
  CommutationOutput out;
  motor.reset(0.0);
  int steps = 0;
  while (!motor.status().end_stop() && steps < 5000) {
    law.commutate(motor.truth().position_m, Wrench(force, 0.0, 0.0), out);
    motor.command(std::span<const DriveSetpoint>(out.setpoints.data(), 2), true);
    motor.step(kPeriod);
    ++steps;
  }
  (void)k_hat;
  const TruthState truth = motor.truth();
  REQUIRE(motor.status().end_stop());
  REQUIRE(motor.status().fault());
  REQUIRE_FALSE(motor.status().enabled());
  REQUIRE(truth.position_m == parameters.mechanics.end_stop_max_m);
  REQUIRE(truth.velocity_m_per_s == 0.0);
  REQUIRE(truth.end_stop_collisions == 1);
  // Constant force from rest over 0.11 m: v = √(2·F/m·d).
  REQUIRE(truth.last_impact_speed_m_per_s ==
          Approx(std::sqrt(2.0 * force / parameters.mechanics.translator_mass_kg * 0.11)).epsilon(5e-3));
  REQUIRE(truth.currents_A.isZero(0.0));
  for (int k = 0; k < 10; ++k) motor.step(kPeriod);
  REQUIRE(motor.truth().position_m == parameters.mechanics.end_stop_max_m);

  // After clear_fault the drive may move away from the stop.
  motor.clear_fault();
  for (int k = 0; k < 200; ++k) {
    law.commutate(motor.truth().position_m, Wrench(-force, 0.0, 0.0), out);
    motor.command(std::span<const DriveSetpoint>(out.setpoints.data(), 2), true);
    motor.step(kPeriod);
  }
  REQUIRE(motor.truth().position_m < parameters.mechanics.end_stop_max_m - 0.01);
  REQUIRE(motor.truth().end_stop_collisions == 1);
  REQUIRE_FALSE(motor.status().fault());
}

TEST_CASE("step uses at least 10 substeps and none longer than integration_step_s", "[sim][motor][mechanics]") {
  MotorParameters parameters = fixtures::ideal_motor(1);
  parameters.mechanics.integration_step_s = 5e-5;
  const SimulatedMotor motor(parameters);
  REQUIRE(motor.substeps(1e-3) == 20);
  REQUIRE(motor.substeps(2.5e-4) == 10);
  REQUIRE(motor.substeps(1e-4) == 10);
  REQUIRE(motor.substeps(1.01e-3) == 21);
  parameters.mechanics.integration_step_s = 3e-4;
  REQUIRE(SimulatedMotor(parameters).substeps(1e-3) == 10);
}

TEST_CASE("sensors: encoder quantisation, force noise and bias with the configured statistics", "[sim][motor][sensors]") {
  MotorParameters parameters = fixtures::ideal_motor(3);
  parameters.sensors.encoder_resolution_m = 1e-6;
  parameters.sensors.force_noise_N_N_Nm = {0.8, 0.4, 0.1};
  parameters.sensors.force_bias_N_N_Nm = {0.5, -0.2, 0.03};
  SimulatedMotor motor(parameters);
  motor.reset(0.0123456);
  const int n = 40000;
  Wrench sum = Wrench::Zero();
  Wrench sum_squares = Wrench::Zero();
  for (int k = 0; k < n; ++k) {
    const SensorFrame frame = motor.sense();
    REQUIRE(frame.position_m == 1e-6 * std::round(0.0123456 / 1e-6));
    sum += frame.wrench;
    sum_squares += frame.wrench.cwiseProduct(frame.wrench);
  }
  const Wrench mean = sum / n;
  const Wrench variance = sum_squares / n - mean.cwiseProduct(mean);
  for (int q = 0; q < 3; ++q) {
    const double sigma = parameters.sensors.force_noise_N_N_Nm[q];
    REQUIRE(std::abs(mean[q] - parameters.sensors.force_bias_N_N_Nm[q]) < 4.0 * sigma / std::sqrt(n));
    REQUIRE(std::sqrt(variance[q]) == Approx(sigma).epsilon(0.03));
  }
}

TEST_CASE("the same seed and inputs give bit-identical runs, the noise seed changes only the measurements",
          "[sim][motor][determinism]") {
  MotorParameters parameters = fixtures::default_motor();
  MotorParameters other_noise = parameters;
  other_noise.sensors.noise_seed += 1;
  SimulatedMotor a(parameters);
  SimulatedMotor b(parameters);
  SimulatedMotor c(other_noise);
  for (auto* motor : {&a, &b, &c}) motor->reset(-0.05);
  RandomStream inputs(99);
  bool measurement_differs = false;
  for (int k = 0; k < 5000; ++k) {
    DriveSetpoint setpoints[3];
    for (auto& setpoint : setpoints) setpoint = {40.0 * (inputs.uniform() - 0.45), 0.5 * (inputs.uniform() - 0.5)};
    SensorFrame frames[3];
    TruthState truths[3];
    int index = 0;
    for (auto* motor : {&a, &b, &c}) {
      motor->command(setpoints, true);
      motor->step(kPeriod);
      frames[index] = motor->sense();
      truths[index] = motor->truth();
      ++index;
    }
    REQUIRE(frames[0].time_s == frames[1].time_s);
    REQUIRE(frames[0].position_m == frames[1].position_m);
    REQUIRE(frames[0].wrench == frames[1].wrench);
    REQUIRE(truths[0].position_m == truths[1].position_m);
    REQUIRE(truths[0].velocity_m_per_s == truths[1].velocity_m_per_s);
    REQUIRE(truths[0].currents_A == truths[1].currents_A);
    REQUIRE(truths[0].wrench == truths[1].wrench);
    // Open loop, the plant does not see the noise.
    REQUIRE(truths[0].position_m == truths[2].position_m);
    REQUIRE(truths[0].wrench == truths[2].wrench);
    measurement_differs = measurement_differs || frames[0].wrench != frames[2].wrench;
  }
  REQUIRE(a.status().word == b.status().word);
  REQUIRE_FALSE(a.status().fault());
  REQUIRE(measurement_differs);
}

TEST_CASE("command, step, sense, status and truth do not allocate", "[sim][motor][realtime]") {
  SimulatedMotor motor(fixtures::default_motor());
  motor.reset(0.0);
  DriveSetpoint setpoints[3] = {{5.0, 0.1}, {5.0, -0.1}, {5.0, 0.0}};
  double checksum = 0.0;
  const clm::test::AllocationScope scope;
  for (int k = 0; k < 5000; ++k) {
    setpoints[0].magnitude_N = 10.0 * std::sin(0.01 * k);
    motor.command(setpoints, true);
    motor.step(kPeriod);
    const SensorFrame frame = motor.sense();
    checksum += frame.wrench.x() + motor.truth().position_m + motor.status().word;
  }
  REQUIRE(scope.allocations() == 0);
  REQUIRE(std::isfinite(checksum));
}

TEST_CASE("reset refuses positions outside the end stops", "[sim][motor]") {
  SimulatedMotor motor(fixtures::ideal_motor(1));
  REQUIRE_THROWS_AS(motor.reset(0.5), ParameterError);
  REQUIRE_NOTHROW(motor.reset(0.11));
}

TEST_CASE("the drive reports Enabled and applies current only after its enable delay", "[sim][motor][drive-signals]") {
  MotorParameters parameters = fixtures::ideal_motor(1);
  parameters.drive.enable_delay_s = 0.003;
  SimulatedMotor motor(parameters);
  motor.reset(0.0);
  const std::vector<DriveSetpoint> push{{50.0, 0.0}};
  int steps = 0;
  while (!motor.status().enabled()) {
    REQUIRE(motor.command(push, true) == CommandResult::kAccepted);
    CHECK(motor.truth().currents_A.cwiseAbs().maxCoeff() == 0.0);
    motor.step(1e-3);
    REQUIRE(++steps < 10);
  }
  // Enabled from the first period boundary at or after 3 ms.
  CHECK(steps == 3);
  REQUIRE(motor.command(push, true) == CommandResult::kAccepted);
  motor.step(1e-3);
  CHECK(motor.truth().currents_A.cwiseAbs().maxCoeff() > 0.1);
  CHECK_FALSE(motor.status().fault());
}

TEST_CASE("a limit switch reports EndStop while the translator is beyond it, without a fault, and push_to keeps the drive",
          "[sim][motor][drive-signals]") {
  MotorParameters parameters = fixtures::ideal_motor(1);
  parameters.mechanics.limit_switch_max_m = 0.1;
  SimulatedMotor motor(parameters);
  motor.reset(0.0);
  const std::vector<DriveSetpoint> zero{{0.0, 0.0}};
  REQUIRE(motor.command(zero, true) == CommandResult::kAccepted);
  motor.step(1e-3);
  REQUIRE(motor.status().enabled());
  CHECK_FALSE(motor.status().end_stop());
  motor.push_to(0.1005);
  CHECK(motor.truth().position_m == 0.1005);
  CHECK(motor.status().end_stop());
  CHECK(motor.status().enabled());  // the push kept the drive as it was
  CHECK_FALSE(motor.status().fault());
  motor.push_to(0.099);
  CHECK_FALSE(motor.status().end_stop());  // not latched
  // Outside the end stops, or in the wrong order, the file's values are refused.
  parameters.mechanics.limit_switch_max_m = 0.2;
  CHECK_THROWS_WITH(parameters.validate(), Catch::Contains("limit_switch_max_m"));
  parameters.mechanics.limit_switch_max_m = 0.1;
  parameters.mechanics.limit_switch_min_m = 0.1;
  CHECK_THROWS_WITH(parameters.validate(), Catch::Contains("limit_switch_max_m"));
  CHECK_THROWS_AS(motor.push_to(0.5), ParameterError);
}

TEST_CASE("the shipped motor files carry limit switches inside their end stops and an enable delay",
          "[sim][motor][drive-signals]") {
  for (const char* file : {"config/motor-sim.yaml", "config/motor-sim-2coil.yaml", "config/motor-sim-4coil.yaml",
                           "config/motor-sim-phase-current.yaml"}) {
    INFO(file);
    const MotorParameters m = load_motor_parameters(fixtures::source_path(file));
    CHECK(m.mechanics.limit_switch_min_m > m.mechanics.end_stop_min_m);
    CHECK(m.mechanics.limit_switch_min_m < m.stroke_min_m);
    CHECK(m.mechanics.limit_switch_max_m < m.mechanics.end_stop_max_m);
    CHECK(m.mechanics.limit_switch_max_m > m.stroke_max_m);
    CHECK(m.drive.enable_delay_s == 0.002);
  }
}
