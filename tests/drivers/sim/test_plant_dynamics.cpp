// The simulated plant's dynamics beyond a rigid mass (docs/simulator.md,
// "The plant's dynamics"), each against its analytic response: the flexible
// mode's step response, the current loop's first-order step, the bridge's
// voltage limit with the back-EMF, the setpoint and encoder delays, the
// encoder's interpolation error, the disturbance's RMS and band.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <numbers>
#include <vector>

#include "config/yaml_reader.hpp"
#include "support/ideal_plant.hpp"
#include "commutation/classical.hpp"
#include "commutation/current_loop_compensation.hpp"
#include "commutation/model_file.hpp"
#include "commutation/transform.hpp"
#include "drivers/sim/current_loop.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/motor_file.hpp"
#include "sim_support.hpp"

using namespace clm;
using namespace clm::sim;

namespace {

constexpr double kPiRad = std::numbers::pi;

/// An ideal one-coil-set motor taking phase currents, without friction, noise
/// or quantisation: what is left is the term under test.
MotorParameters bare_motor(double pole_pitch_m = 0.032) {
  MotorParameters motor = fixtures::ideal_motor(1, pole_pitch_m);
  fixtures::ideal_sensors(motor);
  motor.drive.profile = DriveProfile::kPhaseCurrent;
  motor.drive.watchdog_timeout_s = 1.0;
  motor.mechanics.end_stop_min_m = -1.0;
  motor.mechanics.end_stop_max_m = 1.0;
  return motor;
}

/// bare_motor() held still (1e6 kg) under a disturbance of 0.5 N RMS in [low_Hz, high_Hz].
MotorParameters disturbed_motor(double low_Hz, double high_Hz) {
  MotorParameters parameters = bare_motor();
  parameters.mechanics.translator_mass_kg = 1e6;
  auto& d = parameters.mechanics.force_disturbance;
  d.rms_N = 0.5;
  d.low_Hz = low_Hz;
  d.high_Hz = high_Hz;
  return parameters;
}

}  // namespace

TEST_CASE("The flexible mode's relative motion follows the analytic step response", "[sim][plant]") {
  MotorParameters parameters = bare_motor();
  auto& mode = parameters.mechanics.flexible_mode;
  mode.frequency_Hz = 300.0;
  mode.damping_ratio = 0.03;
  mode.encoder_mass_fraction = 0.3;
  SimulatedMotor motor(parameters);
  // A force step on the motor's side: the read head follows through the
  // spring; the relative coordinate r = x₁ − x₂ settles at m₂·F/(m·k).
  const double force_N = 20.0, m = parameters.mechanics.translator_mass_kg;
  const double omega = 2.0 * kPiRad * mode.frequency_Hz, zeta = mode.damping_ratio;
  const double m2 = mode.encoder_mass_fraction * m, mu = (1.0 - mode.encoder_mass_fraction) * m2;
  const double settled_m = m2 * force_N / (m * omega * omega * mu);
  const double omega_d = omega * std::sqrt(1.0 - zeta * zeta);
  motor.set_disturbance_force_N(force_N);
  double worst = 0.0;
  for (int k = 1; k <= 300; ++k) {
    REQUIRE(motor.step(1e-4) == StepResult::kOk);
    const double t = k * 1e-4;
    const auto truth = motor.truth();
    const double r = truth.position_m - truth.encoder_side_position_m;
    const double expected = settled_m * (1.0 - std::exp(-zeta * omega * t) *
                                                   (std::cos(omega_d * t) + zeta / std::sqrt(1.0 - zeta * zeta) *
                                                                                std::sin(omega_d * t)));
    worst = std::max(worst, std::abs(r - expected));
    // The encoder reads the read head's side.
    REQUIRE(motor.sense().position_m == truth.encoder_side_position_m);
  }
  INFO("relative deflection settles at " << settled_m << " m; largest deviation " << worst << " m");
  CHECK(worst <= 0.01 * settled_m);
}

TEST_CASE("The current loop follows a step as ω_c/(s + ω_c)", "[sim][plant]") {
  MotorParameters parameters = bare_motor();
  parameters.mechanics.translator_mass_kg = 1e6;  // at rest: no back-EMF
  auto& loop = parameters.drive.current_loop;
  loop.bandwidth_Hz = 1000.0;
  loop.phase_resistance_ohm = 2.0;
  loop.phase_inductance_H = 1e-3;
  loop.voltage_limit_V = 150.0;  // K_p·1 A = 6.3 V: far from it
  SimulatedMotor motor(parameters);
  const PhaseCurrentSetpoint step[] = {{1.0, -0.5}};
  REQUIRE(motor.command_currents(step, true) == CommandResult::kAccepted);
  for (int k = 1; k <= 30; ++k) {
    REQUIRE(motor.step(1e-4) == StepResult::kOk);
    const double t = k * 1e-4;
    const double follows = 1.0 - std::exp(-2.0 * kPiRad * loop.bandwidth_Hz * t);
    const auto currents = motor.truth().currents_A;
    INFO("t = " << t << " s");
    CHECK(currents[0] == Approx(1.0 * follows).epsilon(1e-6));
    CHECK(currents[1] == Approx(-0.5 * follows).epsilon(1e-6));
  }
}

TEST_CASE("A step's wrench is that of its mean currents: a current loop's rise counts, its end does not", "[sim][plant]") {
  MotorParameters parameters = bare_motor();
  parameters.mechanics.translator_mass_kg = 1e6;  // at rest: no back-EMF, one position
  auto& loop = parameters.drive.current_loop;
  loop.bandwidth_Hz = 300.0;  // ω_c·T = 1.9 over a 1 ms period: the rise is a third of the mean
  loop.phase_resistance_ohm = 2.0;
  loop.phase_inductance_H = 1e-3;
  loop.voltage_limit_V = 150.0;
  SimulatedMotor motor(parameters);
  const double y = motor.truth().position_m;
  const double period_s = 1e-3;
  const int n = motor.substeps(period_s);
  REQUIRE(n >= 10);
  const PhaseCurrentSetpoint step[] = {{2.0, -1.5}};
  REQUIRE(motor.command_currents(step, true) == CommandResult::kAccepted);
  REQUIRE(motor.step(period_s) == StepResult::kOk);
  // The loop follows ω_c/(s + ω_c) (the case above): at the substeps' ends
  // the currents are I·(1 − exp(−ω_c·j·h)), j = 1..n.
  const double omega = 2.0 * kPiRad * loop.bandwidth_Hz, h = period_s / n;
  double mean_fraction = 0.0;
  for (int j = 1; j <= n; ++j) mean_fraction += (1.0 - std::exp(-omega * j * h)) / n;
  CurrentVector mean(2);
  mean << 2.0 * mean_fraction, -1.5 * mean_fraction;
  const Wrench expected = motor.electromagnetics().wrench(y, 0.0, mean);
  const TruthState truth = motor.truth();
  INFO("mean fraction " << mean_fraction << ", at the end " << 1.0 - std::exp(-omega * period_s));
  CHECK((truth.step_wrench - expected).cwiseAbs().maxCoeff() < 1e-6 * (1.0 + expected.norm()));  // the loop's own accuracy, above
  // At the step's end the current is near its setpoint: that wrench is larger by a third.
  CHECK(std::abs(truth.wrench.x()) > 1.2 * std::abs(truth.step_wrench.x()));
  // A second step, the current nearly settled: the two differ by the rest of
  // the rise, 1 − exp(−ω_c·T)·(1 − exp(−ω_c·T))/(ω_c·T) = 0.93 against 0.98 at the end.
  REQUIRE(motor.step(period_s) == StepResult::kOk);
  const TruthState settled = motor.truth();
  CHECK(settled.step_wrench.x() == Approx(settled.wrench.x()).epsilon(0.1));
  CHECK(std::abs(settled.step_wrench.x()) < std::abs(settled.wrench.x()));
}

TEST_CASE("At the voltage limit the winding's current rises as (V − e)/R·(1 − exp(−R·t/L)), with the back-EMF", "[sim][plant]") {
  // A pole pitch of 100 m keeps the force constant (and so the back-EMF per
  // m/s) the same over the millimetres moved.
  MotorParameters parameters = bare_motor(100.0);
  parameters.mechanics.translator_mass_kg = 1e6;
  auto& loop = parameters.drive.current_loop;
  loop.bandwidth_Hz = 1000.0;
  loop.phase_resistance_ohm = 2.0;
  loop.phase_inductance_H = 1e-3;
  loop.voltage_limit_V = 5.0;  // K_p·10 A = 63 V asked: at the limit throughout
  for (const double v : {0.0, 0.2}) {
    SimulatedMotor motor(parameters);
    motor.reset(0.0, v);
    // Phase a's back-EMF: its force constant less the phases' mean, from the
    // gains of the independent currents (columns a − c and b − c).
    const auto gain = motor.true_gain(0, 0.0);
    const double emf_V = v * (2.0 * gain(0, 0) - gain(0, 1)) / 3.0;
    const PhaseCurrentSetpoint step[] = {{10.0, 0.0}};
    REQUIRE(motor.command_currents(step, true) == CommandResult::kAccepted);
    for (int k = 1; k <= 20; ++k) {
      REQUIRE(motor.step(1e-4) == StepResult::kOk);
      const double t = k * 1e-4;
      const double expected = (loop.voltage_limit_V - emf_V) / loop.phase_resistance_ohm *
                              (1.0 - std::exp(-loop.phase_resistance_ohm * t / loop.phase_inductance_H));
      INFO("v = " << v << " m/s, back-EMF " << emf_V << " V, t = " << t << " s");
      CHECK(motor.truth().currents_A[0] == Approx(expected).epsilon(1e-3));
    }
  }
}

TEST_CASE("A setpoint takes effect after the drive's delay, enable at once", "[sim][plant]") {
  MotorParameters parameters = bare_motor();
  parameters.drive.setpoint_delay_s = 3e-4;
  SimulatedMotor motor(parameters);
  const PhaseCurrentSetpoint first[] = {{2.0, 0.0}};
  REQUIRE(motor.command_currents(first, true) == CommandResult::kAccepted);
  REQUIRE(motor.step(2e-4) == StepResult::kOk);
  CHECK(motor.truth().currents_A[0] == 0.0);
  CHECK(motor.status().enabled());
  REQUIRE(motor.step(2e-4) == StepResult::kOk);  // t = 0.4 ms
  CHECK(motor.truth().currents_A[0] == 2.0);
  // Two in flight: each after its own delay.
  const PhaseCurrentSetpoint second[] = {{3.0, 0.0}};
  REQUIRE(motor.command_currents(second, true) == CommandResult::kAccepted);  // due at 0.7 ms
  REQUIRE(motor.step(2e-4) == StepResult::kOk);
  const PhaseCurrentSetpoint third[] = {{4.0, 0.0}};
  REQUIRE(motor.command_currents(third, true) == CommandResult::kAccepted);  // due at 0.9 ms
  REQUIRE(motor.step(2e-4) == StepResult::kOk);  // 0.8 ms
  CHECK(motor.truth().currents_A[0] == 3.0);
  REQUIRE(motor.step(2e-4) == StepResult::kOk);  // 1.0 ms
  CHECK(motor.truth().currents_A[0] == 4.0);
  // Disable acts at once.
  REQUIRE(motor.command_currents(third, false) == CommandResult::kAccepted);
  CHECK(motor.truth().currents_A[0] == 0.0);
}

TEST_CASE("The encoder reports the position its delay ago", "[sim][plant]") {
  MotorParameters parameters = bare_motor();
  parameters.mechanics.translator_mass_kg = 1e6;
  parameters.sensors.encoder_delay_s = 5e-4;
  SimulatedMotor motor(parameters);
  const double v = 0.1;
  motor.reset(0.0, v);
  for (int k = 0; k < 10; ++k) REQUIRE(motor.step(1e-3) == StepResult::kOk);
  const auto truth = motor.truth();
  CHECK(motor.sense().position_m == Approx(truth.position_m - v * 5e-4).margin(1e-12));
}

TEST_CASE("The encoder's interpolation error has its amplitudes at the scale pitch and its half", "[sim][plant]") {
  MotorParameters parameters = bare_motor();
  parameters.sensors.encoder_scale_pitch_m = 20e-6;
  parameters.sensors.encoder_interpolation_error_m = 10e-9;
  parameters.sensors.encoder_interpolation_second_m = 3e-9;
  SimulatedMotor motor(parameters);
  const int n = 64;
  double c1 = 0, s1 = 0, c2 = 0, s2 = 0, mean = 0;
  for (int k = 0; k < n; ++k) {
    const double y = 0.01 + k * 20e-6 / n;
    motor.reset(y);
    const double error = motor.sense().position_m - y;
    const double angle = 2.0 * kPiRad * (y - 0.01) / 20e-6;
    c1 += error * std::cos(angle) * 2 / n;
    s1 += error * std::sin(angle) * 2 / n;
    c2 += error * std::cos(2 * angle) * 2 / n;
    s2 += error * std::sin(2 * angle) * 2 / n;
    mean += error / n;
  }
  CHECK(std::hypot(c1, s1) == Approx(10e-9).epsilon(1e-6));
  CHECK(std::hypot(c2, s2) == Approx(3e-9).epsilon(1e-6));
  CHECK(std::abs(mean) < 1e-15);
}

TEST_CASE("The force disturbance has its RMS and no power outside its band", "[sim][plant]") {
  SimulatedMotor motor(disturbed_motor(5.0, 50.0));
  std::vector<double> force;
  for (int k = 0; k < 40000; ++k) {  // 40 s at 1 kHz
    REQUIRE(motor.step(1e-3) == StepResult::kOk);
    force.push_back(motor.truth().disturbance_N);
  }
  double sum_squares = 0.0;
  for (double f : force) sum_squares += f * f;
  const double rms = std::sqrt(sum_squares / force.size());
  CHECK(rms == Approx(0.5).epsilon(0.05));
  // Power at 1 Hz steps outside [5, 50] Hz against the total (a periodogram
  // of 40 s: 0.025 Hz resolution).
  const auto power_at = [&](double f_Hz) {
    double c = 0, s = 0;
    for (std::size_t k = 0; k < force.size(); ++k) {
      c += force[k] * std::cos(2 * kPiRad * f_Hz * (k + 1) * 1e-3);
      s += force[k] * std::sin(2 * kPiRad * f_Hz * (k + 1) * 1e-3);
    }
    return (c * c + s * s) / (force.size() * force.size());
  };
  double inside = 0.0, outside = 0.0;
  for (double f = 10.0; f <= 40.0; f += 0.5) inside = std::max(inside, power_at(f));
  for (double f = 70.0; f <= 300.0; f += 7.0) outside = std::max(outside, power_at(f));
  INFO("largest line power inside " << inside << " N^2, outside " << outside << " N^2");
  CHECK(outside < 1e-3 * inside);
}

TEST_CASE("A restarted disturbance repeats its first stretch, and one that runs on does not", "[sim][plant]") {
  SimulatedMotor motor(disturbed_motor(1.0, 50.0));
  const auto stretch = [&motor] {
    std::vector<double> force;
    for (int k = 0; k < 2000; ++k) {
      REQUIRE(motor.step(1e-3) == StepResult::kOk);
      force.push_back(motor.truth().disturbance_N);
    }
    return force;
  };
  const std::vector<double> first = stretch();
  const std::vector<double> running_on = stretch();
  motor.restart_disturbance();
  const std::vector<double> restarted = stretch();
  // The phasors are set exactly at time 0 and rotated alike after it.
  for (std::size_t k = 0; k < first.size(); ++k) {
    INFO("step " << k);
    REQUIRE(restarted[k] == Approx(first[k]).margin(1e-12));
  }
  double difference = 0.0;
  for (std::size_t k = 0; k < first.size(); ++k) difference = std::max(difference, std::abs(running_on[k] - first[k]));
  CHECK(difference > 0.1);  // the next 2 s are another stretch (0.5 N RMS)
}

TEST_CASE("Plant settings out of range are refused by name", "[sim][plant]") {
  MotorParameters parameters = bare_motor();
  parameters.mechanics.flexible_mode.frequency_Hz = 5000.0;  // 2π·f·h = 1.6
  CHECK_THROWS_WITH(parameters.validate(), Catch::Contains("flexible_mode.frequency_Hz"));
  parameters = bare_motor();
  parameters.drive.setpoint_delay_s = 0.1;
  CHECK_THROWS_WITH(parameters.validate(), Catch::Contains("setpoint_delay_s"));
  parameters = bare_motor();
  parameters.sensors.encoder_delay_s = -1e-3;
  CHECK_THROWS_WITH(parameters.validate(), Catch::Contains("encoder_delay_s"));
  parameters = bare_motor();
  parameters.mechanics.force_disturbance.high_Hz = 0.5;  // below low_Hz
  CHECK_THROWS_WITH(parameters.validate(), Catch::Contains("force_disturbance.high_Hz"));
}

TEST_CASE("The motor file sets every plant term, and refuses an unknown key in them", "[sim][plant]") {
  std::ifstream in(clm::test::ideal_plant_file("motor-sim.yaml"));  // the shipped motor without its plant terms
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  const auto insert_after = [&](const std::string& anchor, const std::string& lines) {
    const auto at = text.find(anchor);
    REQUIRE(at != std::string::npos);
    text.insert(at + anchor.size(), lines);
  };
  insert_after("\n  mechanics:\n",
               "    flexible_mode: {frequency_Hz: 250.0, damping_ratio: 0.04, encoder_mass_fraction: 0.25}\n"
               "    force_disturbance: {rms_N: 0.3, low_Hz: 2.0, high_Hz: 80.0, seed: 9}\n");
  insert_after("\n  sensors:\n",
               "    encoder_delay_s: 1.0e-4\n    encoder_scale_pitch_m: 4.0e-5\n"
               "    encoder_interpolation_error_m: 5.0e-9\n    encoder_interpolation_second_m: 1.0e-9\n");
  insert_after("\n  drive:\n",  // simulation.drive: (the top-level drive: is not indented)
               "    setpoint_delay_s: 2.5e-4\n"
               "    current_loop: {bandwidth_Hz: 1500.0, phase_resistance_ohm: 3.0, phase_inductance_H: 1.5e-3, "
               "voltage_limit_V: 100.0}\n");
  const MotorParameters m = read_motor_parameters(yaml::Node::load_string(text, "motor.yaml"));
  CHECK(m.mechanics.flexible_mode.frequency_Hz == 250.0);
  CHECK(m.mechanics.flexible_mode.damping_ratio == 0.04);
  CHECK(m.mechanics.flexible_mode.encoder_mass_fraction == 0.25);
  CHECK(m.mechanics.force_disturbance.rms_N == 0.3);
  CHECK(m.mechanics.force_disturbance.high_Hz == 80.0);
  CHECK(m.mechanics.force_disturbance.seed == 9);
  CHECK(m.sensors.encoder_delay_s == 1.0e-4);
  CHECK(m.sensors.encoder_scale_pitch_m == 4.0e-5);
  CHECK(m.sensors.encoder_interpolation_error_m == 5.0e-9);
  CHECK(m.sensors.encoder_interpolation_second_m == 1.0e-9);
  CHECK(m.drive.setpoint_delay_s == 2.5e-4);
  CHECK(m.drive.current_loop.bandwidth_Hz == 1500.0);
  CHECK(m.drive.current_loop.phase_resistance_ohm == 3.0);
  CHECK(m.drive.current_loop.phase_inductance_H == 1.5e-3);
  CHECK(m.drive.current_loop.voltage_limit_V == 100.0);
  std::string misspelt = text;
  misspelt.replace(misspelt.find("damping_ratio"), 13, "damping_ration");
  CHECK_THROWS_WITH(read_motor_parameters(yaml::Node::load_string(misspelt, "motor.yaml")),
                    Catch::Contains("damping_ration"));
}

TEST_CASE("The motor file tells the tools the drive's delays, and the simulator leaves them to its truth",
          "[sim][plant]") {
  std::ifstream in(clm::test::ideal_plant_file("motor-sim.yaml"));  // the shipped motor without its plant terms
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string original = buffer.str();
  const auto with_drive_lines = [&](const std::string& lines) {
    std::string text = original;
    const std::string anchor = "\ndrive:\n";
    const auto at = text.find(anchor);
    REQUIRE(at != std::string::npos);
    return text.insert(at + anchor.size(), lines);
  };
  const std::string text = with_drive_lines("  setpoint_delay_s: 1.8e-4\n  position_delay_s: 9.0e-5\n");
  const MotorDescription description = read_motor_description(yaml::Node::load_string(text, "motor.yaml"));
  CHECK(description.setpoint_delay_s == 1.8e-4);
  CHECK(description.position_delay_s == 9.0e-5);
  // What the daemon is told is not the simulator's truth, which stays as its section says.
  const MotorParameters truth = read_motor_parameters(yaml::Node::load_string(text, "motor.yaml"));
  CHECK(truth.drive.setpoint_delay_s == 0.0);
  CHECK(truth.sensors.encoder_delay_s == 0.0);
  const MotorDescription plain = read_motor_description(yaml::Node::load_string(original, "motor.yaml"));
  CHECK(plain.setpoint_delay_s == 0.0);
  CHECK(plain.position_delay_s == 0.0);
  for (const char* bad : {"  setpoint_delay_s: -1.0e-4\n", "  position_delay_s: 0.5\n", "  position_delay_s: .nan\n"}) {
    INFO(bad);
    CHECK_THROWS_WITH(read_motor_description(yaml::Node::load_string(with_drive_lines(bad), "motor.yaml")),
                      Catch::Contains("delay_s"));
  }
}

namespace {

/// The RMS error of a drive's current loop against the currents a classical
/// law asks for, on one coil set moving as y = v₀t + at²/2 for 0.2 s, with the
/// cycle's setpoints (1 kHz) rotated by the drive's own commutation in every
/// 10 µs substep, as a magnitude/phase drive does; with the references of
/// CurrentLoopCompensation or without them. The back-EMF is the true one.
double current_loop_error_A(bool compensated, double v0_m_per_s, double a_m_per_s2) {
  const double pitch_m = 0.03, period_s = 1e-3, h_s = 1e-5;
  const ClassicalCoilSet truth{60.0, 0.3, 0.0, 0.0};
  const ClassicalEstimate law{truth.motor_constant_N_per_A, truth.phase_offset_rad};
  const DriveCommutation drive{67.0, -0.52};
  CurrentLoopParameters loop_parameters;
  loop_parameters.bandwidth_Hz = 1500.0;
  loop_parameters.phase_resistance_ohm = 2.0;
  loop_parameters.phase_inductance_H = 1e-3;
  loop_parameters.voltage_limit_V = 1e6;  // linear: the compensation's subject
  CurrentLoop loop(loop_parameters);
  loop.reset(2);
  CurrentLoopCompensation compensation({1500.0, 2.0, 1e-3}, period_s);
  const double force_N = 100.0;
  const auto law_currents = [&](double y_m) {
    CurrentVector i(2);
    classical_currents(std::span<const ClassicalEstimate>(&law, 1), pitch_m, y_m, force_N, i);
    return i;
  };
  double sum_A2 = 0.0;
  long count = 0;
  const int substeps = static_cast<int>(std::lround(period_s / h_s));
  for (int n = 0; n < 200; ++n) {
    const double t_s = n * period_s;
    const double y_m = v0_m_per_s * t_s + 0.5 * a_m_per_s2 * t_s * t_s;
    const double v_m_per_s = v0_m_per_s + a_m_per_s2 * t_s;
    const double lead_m = compensated ? v_m_per_s * compensation.lead_s() : 0.0;
    CurrentVector reference = law_currents(y_m + lead_m);
    if (compensated) {
      const CurrentVector gain = classical_gain(truth, y_m + lead_m, pitch_m).row(0).transpose();
      const CurrentVector currents = reference;
      compensation.references(currents, gain, v_m_per_s, reference);
    }
    const DriveSetpoint setpoint =
        setpoint_from_currents(drive, y_m, pitch_m, reference.head<2>(), PhaseConvention::kSignedMagnitude);
    for (int k = 0; k < substeps; ++k) {
      // The substep's reference and back-EMF, held, at its midpoint.
      const double t = t_s + k * h_s, t_mid = t + 0.5 * h_s;
      const double y = v0_m_per_s * t_mid + 0.5 * a_m_per_s2 * t_mid * t_mid;
      const double v = v0_m_per_s + a_m_per_s2 * t_mid;
      CurrentVector r(2), emf(2);
      r = drive_phase_currents(drive, setpoint, y, pitch_m);
      const Eigen::RowVector2d g = classical_gain(truth, y, pitch_m).row(0);
      emf << v * (2.0 * g[0] - g[1]) / 3.0, v * (2.0 * g[1] - g[0]) / 3.0;  // phases less their mean
      loop.step(r, emf, h_s);
      const double t_after = t + h_s;
      const CurrentVector wanted = law_currents(v0_m_per_s * t_after + 0.5 * a_m_per_s2 * t_after * t_after);
      if (n >= 50) {  // after the loop's and the differences' start
        sum_A2 += (loop.current_A() - wanted).squaredNorm();
        ++count;
      }
    }
  }
  return std::sqrt(sum_A2 / static_cast<double>(count));
}

}  // namespace

TEST_CASE("The current loop's compensation delivers the law's currents through the back-EMF and the lag",
          "[sim][plant][compensation]") {
  // Uncompensated, a PI loop tuned by pole-zero cancellation lags by about
  // 1/ω_c (0.11 ms, 0.6° of electrical angle at 0.5 m/s on a 30 mm pitch)
  // and lets through s/((Ls + R)(s + ω_c)) of the back-EMF (about 30 V at
  // 0.5 m/s). What the compensation leaves is of second order in ω_e·T
  // (0.1 rad at 0.5 m/s and a 1 ms cycle: the back-EMF's differences),
  // ω_e/ω_c and ω_e·L/R: about 1 %.
  for (const auto& [v0, a] : {std::pair{0.5, 0.0}, std::pair{-0.3, 0.0}, std::pair{0.05, 4.0}}) {
    const double without_A = current_loop_error_A(false, v0, a);
    const double with_A = current_loop_error_A(true, v0, a);
    INFO("v0 " << v0 << " m/s, a " << a << " m/s^2: RMS current error " << without_A << " A without, " << with_A
               << " A with the compensation");
    CHECK(without_A > 0.02);           // the loop's error is there to compensate
    CHECK(with_A < 0.02 * without_A);  // and the compensation removes at least 98 % of it
  }
}

TEST_CASE("The current loop's compensation is off without a current loop and starts without a derivative",
          "[sim][plant][compensation]") {
  CurrentLoopCompensation ideal({}, 1e-3);
  CHECK_FALSE(ideal.active());
  CHECK(ideal.lead_s() == 0.0);
  CurrentVector currents(2), gain(2), out(2);
  currents << 1.0, -2.0;
  gain << 30.0, 40.0;
  ideal.references(currents, gain, 0.5, out);
  CHECK(out == currents);
  CurrentLoopCompensation loop({1000.0, 2.0, 1e-3}, 1e-3);
  CHECK(loop.lead_s() == Approx(1.0 / (2.0 * kPiRad * 1000.0)));
  loop.references(currents, gain, 0.5, out);  // the first cycle: no back-EMF history
  CHECK(out == currents);
  // The second: the difference of the phases' back-EMF over 1 ms, over
  // R·ω_c. Phase a's constant less the mean is (2·30 − 40)/3, b's (2·40 − 30)/3.
  loop.references(currents, gain, 0.6, out);
  const double scale = 1.0 / (2.0 * (2.0 * kPiRad * 1000.0));
  CHECK(out[0] == Approx(currents[0] + scale * 0.1 * (20.0 / 3.0) / 1e-3));
  CHECK(out[1] == Approx(currents[1] + scale * 0.1 * (50.0 / 3.0) / 1e-3));
  REQUIRE_THROWS_WITH(CurrentLoopCompensation({1000.0, -1.0, 1e-3}, 1e-3),
                      Catch::Contains("phase_resistance_ohm"));
}

TEST_CASE("drive.current_loop of the motor file is read, and refused out of range by file, line and key",
          "[sim][plant][compensation]") {
  const auto motor_text = [](const std::string& loop) {
    return "motor: {pole_pitch_m: 0.03, coil_sets: 3}\n"
           "drive:\n"
           "  commutation: {motor_constant_N_per_A: 67.0, phase_offset_rad: -0.52}\n"
           "  current_loop: " + loop + "\n";
  };
  const MotorDescription read = read_motor_description(yaml::Node::load_string(
      motor_text("{bandwidth_Hz: 1350.0, phase_resistance_ohm: 2.2, phase_inductance_H: 0.0011}"), "m.yaml"));
  CHECK(read.current_loop.bandwidth_Hz == 1350.0);
  CHECK(read.current_loop.phase_resistance_ohm == 2.2);
  CHECK(read.current_loop.phase_inductance_H == 0.0011);
  CHECK(read_motor_description(yaml::Node::load_string(
                                   "motor: {pole_pitch_m: 0.03, coil_sets: 3}\n"
                                   "drive:\n  commutation: {motor_constant_N_per_A: 67.0, phase_offset_rad: -0.52}\n",
                                   "m.yaml"))
            .current_loop.ideal());
  for (const auto& [loop, key] : {std::pair{std::string("{bandwidth_Hz: 0.5, phase_resistance_ohm: 2, phase_inductance_H: 0.001}"),
                                            std::string("drive.current_loop.bandwidth_Hz")},
                                  std::pair{std::string("{bandwidth_Hz: 1500, phase_resistance_ohm: 0, phase_inductance_H: 0.001}"),
                                            std::string("drive.current_loop.phase_resistance_ohm")},
                                  std::pair{std::string("{bandwidth_Hz: 1500, phase_resistance_ohm: 2, phase_inductance_H: 11}"),
                                            std::string("drive.current_loop.phase_inductance_H")},
                                  std::pair{std::string("{bandwidth_Hz: 1500, phase_resistance_ohm: 2, inductance: 0.001}"),
                                            std::string("inductance")}}) {
    INFO(loop);
    REQUIRE_THROWS_WITH(read_motor_description(yaml::Node::load_string(motor_text(loop), "m.yaml")),
                        Catch::StartsWith("m.yaml:4: ") && Catch::Contains(key));
  }
}

TEST_CASE("A payload adds its mass to the translator's, also with a flexible mode, and is refused out of range",
          "[sim][plant]") {
  // A constant external force F on the bare motor at rest (no friction, drive
  // off): after t the velocity is F·t/(m + payload) exactly (semi-implicit
  // Euler integrates a constant acceleration exactly in velocity). With a
  // flexible mode the two sides' momentum is still F·t.
  for (const bool flexible : {false, true}) {
    INFO((flexible ? "flexible mode at 300 Hz" : "rigid translator"));
    MotorParameters parameters = bare_motor();
    if (flexible) parameters.mechanics.flexible_mode = {300.0, 0.02, 0.3};
    SimulatedMotor motor(parameters);
    const double mass_kg = parameters.mechanics.translator_mass_kg;
    const double payload_kg = 0.4 * mass_kg, force_N = 12.0, seconds = 0.2;
    motor.set_payload_kg(payload_kg);
    motor.reset(0.0);
    CHECK(motor.payload_kg() == payload_kg);  // kept across reset()
    motor.set_disturbance_force_N(force_N);
    for (int k = 0; k < 200; ++k) motor.step(seconds / 200);
    const TruthState truth = motor.truth();
    const double momentum_N_s =
        flexible ? (payload_kg + 0.7 * mass_kg) * truth.velocity_m_per_s + 0.3 * mass_kg * truth.encoder_side_velocity_m_per_s
                 : (payload_kg + mass_kg) * truth.velocity_m_per_s;
    CHECK(momentum_N_s == Approx(force_N * seconds).epsilon(1e-9));
    if (!flexible) CHECK(truth.velocity_m_per_s == Approx(force_N * seconds / (mass_kg + payload_kg)).epsilon(1e-12));
  }
  SimulatedMotor motor(bare_motor());
  const double limit_kg = SimulatedMotor::kMaxPayloadRatio * bare_motor().mechanics.translator_mass_kg;
  for (const double bad : {-1e-3, 1.01 * limit_kg, std::nan(""), std::numeric_limits<double>::infinity()}) {
    INFO("payload " << bad << " kg");
    CHECK_THROWS_WITH(motor.set_payload_kg(bad), Catch::Contains("payload_kg"));
  }
  CHECK(motor.payload_kg() == 0.0);
}

TEST_CASE("The ideal drive's wrench is what a drive without loop or delay makes of the same setpoints", "[sim][plant]") {
  // Magnitude/phase: the drive's own commutation at the position, then its
  // current limit. The ideal drive's one step at rest is the reference; a
  // drive with a current loop and a delay gives the same ideal-drive wrench
  // (it does not depend on the drive's state) but another step.
  MotorParameters ideal = bare_motor();
  ideal.drive.profile = DriveProfile::kMagnitudePhase;
  ideal.mechanics.translator_mass_kg = 1e6;  // at rest: one position over the step
  MotorParameters slow = ideal;
  slow.drive.setpoint_delay_s = 4e-4;
  slow.drive.current_loop.bandwidth_Hz = 300.0;
  slow.drive.current_loop.phase_resistance_ohm = 2.0;
  slow.drive.current_loop.phase_inductance_H = 1e-3;
  slow.drive.current_loop.voltage_limit_V = 150.0;
  for (const double magnitude_N : {40.0, -25.0, 1e4}) {  // 1e4 N: far beyond the current limit
    INFO("magnitude " << magnitude_N << " N");
    const DriveSetpoint setpoint[] = {{magnitude_N, 0.3}};
    SimulatedMotor motor(ideal), lagging(slow);
    const double y = motor.truth().position_m;
    const Wrench expected = motor.ideal_drive_wrench(y, setpoint, {});
    REQUIRE(motor.command(setpoint, true) == CommandResult::kAccepted);
    REQUIRE(motor.step(1e-3) == StepResult::kOk);
    const Wrench made = motor.truth().step_wrench;
    // At 1e6 kg the step moves the translator by under 1 nm, 10⁻⁷ of the pitch in angle.
    CHECK((made - expected).cwiseAbs().maxCoeff() < 1e-6 * (1.0 + expected.norm()));
    CHECK(std::abs(expected.x()) > 1.0);
    REQUIRE(lagging.command(setpoint, true) == CommandResult::kAccepted);
    REQUIRE(lagging.step(1e-3) == StepResult::kOk);
    CHECK(lagging.ideal_drive_wrench(y, setpoint, {}) == expected);
    CHECK(std::abs(lagging.truth().step_wrench.x()) < 0.8 * std::abs(expected.x()));
  }
  // Phase currents: the currents as given, limited.
  MotorParameters currents_drive = ideal;
  currents_drive.drive.profile = DriveProfile::kPhaseCurrent;
  SimulatedMotor motor(currents_drive);
  const double y = motor.truth().position_m;
  const PhaseCurrentSetpoint currents[] = {{2.0, -1.5}};
  CurrentVector phase(2);
  phase << 2.0, -1.5;
  const Wrench expected = motor.electromagnetics().wrench(y, 0.0, phase);
  CHECK((motor.ideal_drive_wrench(y, {}, currents) - expected).cwiseAbs().maxCoeff() < 1e-12 * (1.0 + expected.norm()));
  // Too few entries for the coil sets: no currents, no force.
  CHECK(motor.ideal_drive_wrench(y, {}, {}) == Wrench::Zero());
}
