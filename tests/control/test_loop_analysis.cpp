// The position loop's margins (daemon/control/loop_analysis.hpp) against
// the analytic phase margin of the tuning rule, the zero-order hold's and a
// delay's phase lag, an independent state-space solution of the two-mass
// plant, and the gain margin's own definition.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <cmath>
#include <complex>
#include <limits>
#include <vector>

#include "daemon/control/loop_analysis.hpp"

using namespace clm::control;

namespace {
constexpr double kPiRad = 3.141592653589793;
double degrees(double rad) { return rad * 180.0 / kPiRad; }
/// The tuning rule's continuous-time phase margin (tune_pid): atan(√3 − 1/5) − atan(1/5).
double rule_margin_deg() { return degrees(std::atan(std::sqrt(3.0) - 0.2) - std::atan(0.2)); }
}  // namespace

TEST_CASE("A fast-sampled rigid loop has the tuning rule's crossover and phase margin", "[control][margins]") {
  const PidGains gains = tune_pid(15.0, 40.0);
  const LoopMargins m = loop_margins(gains, 1e-6, PlantModel{.mass_kg = 15.0});
  CHECK(m.crossover_Hz == Approx(40.0).epsilon(0.005));
  CHECK(m.phase_margin_deg == Approx(rule_margin_deg()).margin(0.2));
  CHECK(m.gain_crossovers == 1);
  CHECK(m.gain_margin_dB > 20.0);
}

TEST_CASE("Sampling costs the hold's ωT/2 of phase, a delay its ωτ", "[control][margins]") {
  const PidGains gains = tune_pid(15.0, 40.0);
  const double period_s = 1e-3;
  const LoopMargins sampled = loop_margins(gains, period_s, PlantModel{.mass_kg = 15.0});
  const double w = 2.0 * kPiRad * sampled.crossover_Hz;
  CHECK(sampled.crossover_Hz == Approx(40.0).epsilon(0.01));
  CHECK(sampled.phase_margin_deg == Approx(rule_margin_deg() - degrees(w * period_s / 2.0)).margin(0.3));
  const LoopMargins delayed = loop_margins(gains, period_s, PlantModel{.mass_kg = 15.0, .delay_s = 5e-4});
  CHECK(delayed.crossover_Hz == Approx(sampled.crossover_Hz).epsilon(1e-6));
  CHECK(sampled.phase_margin_deg - delayed.phase_margin_deg == Approx(degrees(w * 5e-4)).margin(0.01));
}

TEST_CASE("The flexible plant's response is the two-mass system's, solved independently", "[control][margins]") {
  // x = [x₁, v₁, x₂, v₂]: m₁·v₁' = F − k(x₁ − x₂) − c(v₁ − v₂), m₂·v₂' = k(x₁ − x₂) + c(v₁ − v₂); y = x₂.
  const double m = 15.0, fraction = 0.3, f_mode = 300.0, zeta = 0.03;
  const double m1 = (1 - fraction) * m, m2 = fraction * m, mu = m1 * m2 / m, w_mode = 2 * kPiRad * f_mode;
  const double k = w_mode * w_mode * mu, c = 2 * zeta * w_mode * mu;
  Eigen::Matrix4d a;
  a << 0, 1, 0, 0, -k / m1, -c / m1, k / m1, c / m1, 0, 0, 0, 1, k / m2, c / m2, -k / m2, -c / m2;
  const Eigen::Vector4d b(0, 1 / m1, 0, 0);
  const PlantModel plant{.mass_kg = m, .mode_frequency_Hz = f_mode, .mode_damping_ratio = zeta};
  for (double f : {5.0, 80.0, 290.0, 300.0, 310.0, 450.0}) {
    const std::complex<double> s(0.0, 2 * kPiRad * f);
    const Eigen::Matrix4cd system = s * Eigen::Matrix4cd::Identity() - a.cast<std::complex<double>>();
    const Eigen::Vector4cd x = system.partialPivLu().solve(b.cast<std::complex<double>>());
    const std::complex<double> p = plant_response(plant, f);
    INFO("f = " << f << " Hz");
    CHECK(std::abs(p - x(2)) <= 1e-9 * std::abs(x(2)));
  }
}

TEST_CASE("Scaling the gains by the gain margin brings the loop to the edge", "[control][margins]") {
  const PidGains gains = tune_pid(15.0, 40.0);
  const PlantModel plant{.mass_kg = 15.0,
                         .mode_frequency_Hz = 300.0,
                         .mode_damping_ratio = 0.02,
                         .current_loop_bandwidth_Hz = 1500.0,
                         .delay_s = 3e-4};
  const LoopMargins m = loop_margins(gains, 1e-3, plant);
  REQUIRE(std::isfinite(m.gain_margin_dB));
  INFO("gain margin " << m.gain_margin_dB << " dB at " << m.gain_margin_Hz << " Hz, phase margin "
                      << m.phase_margin_deg << " deg at " << m.crossover_Hz << " Hz");
  const double g = std::pow(10.0, m.gain_margin_dB / 20.0);
  PidGains scaled = gains;
  scaled.proportional_N_per_m *= g;
  scaled.integral_N_per_m_s *= g;
  scaled.derivative_N_s_per_m *= g;
  // At the phase crossover the scaled loop is −1: |L| = 1 there.
  CHECK(std::abs(loop_response(scaled, 1e-3, plant, m.gain_margin_Hz)) == Approx(1.0).epsilon(0.01));
  const LoopMargins edge = loop_margins(scaled, 1e-3, plant);
  CHECK(std::abs(edge.gain_margin_dB) < 0.05);
}

TEST_CASE("Margins refuse a period or mass that is not positive", "[control][margins]") {
  const PidGains gains = tune_pid(15.0, 40.0);
  CHECK_THROWS_AS(loop_margins(gains, 0.0, PlantModel{.mass_kg = 15.0}), std::invalid_argument);
  CHECK_THROWS_AS(loop_margins(gains, 1e-3, PlantModel{}), std::invalid_argument);
}

TEST_CASE("A lightly damped mode adds crossings, and costs margin only where it swings towards -1", "[control][margins]") {
  const PidGains gains = tune_pid(15.0, 40.0);
  const PlantModel rigid{.mass_kg = 15.0, .current_loop_bandwidth_Hz = 1500.0, .delay_s = 3e-4};
  PlantModel flexible = rigid;
  flexible.mode_frequency_Hz = 300.0;
  flexible.mode_damping_ratio = 0.02;
  const LoopMargins r = loop_margins(gains, 1e-3, rigid);
  const LoopMargins f = loop_margins(gains, 1e-3, flexible);
  CHECK(r.gain_crossovers == 1);
  CHECK(f.gain_crossovers == 3);
  // At the mode the loop's phase is near the rigid loop's minus 90°: its
  // resonance swings away from −1, and the rigid crossover keeps the margin.
  const std::complex<double> at_mode = loop_response(gains, 1e-3, flexible, 300.0);
  CHECK(std::abs(at_mode) > 1.0);
  CHECK(std::abs(at_mode + 1.0) > 1.0);
  CHECK(f.phase_margin_deg == Approx(r.phase_margin_deg).margin(0.5));
  // The same mode at 150 Hz, nearer the crossover, swings through −1's side.
  flexible.mode_frequency_Hz = 150.0;
  const LoopMargins near = loop_margins(gains, 1e-3, flexible);
  CHECK(near.gain_margin_dB < 6.0);
  CHECK(near.peak_sensitivity > 2.0);
}

TEST_CASE("The described plant is the motor file's mode, current loop and the sum of its delays", "[control][margins]") {
  clm::MotorDescription motor;
  motor.flexible_mode_Hz = 280.0;
  motor.flexible_mode_damping_ratio = 0.03;
  motor.current_loop.bandwidth_Hz = 1350.0;
  motor.setpoint_delay_s = 1.8e-4;
  motor.position_delay_s = 9e-5;
  const PlantModel plant = described_plant(motor, 15.45);
  CHECK(plant.mass_kg == 15.45);
  CHECK(plant.mode_frequency_Hz == 280.0);
  CHECK(plant.mode_damping_ratio == 0.03);
  CHECK(plant.current_loop_bandwidth_Hz == 1350.0);
  CHECK(plant.delay_s == Approx(2.7e-4).epsilon(1e-12));
  const PlantModel rigid = described_plant(clm::MotorDescription{}, 15.0);
  CHECK(rigid.mode_frequency_Hz == 0.0);
  CHECK(rigid.current_loop_bandwidth_Hz == 0.0);
  CHECK(rigid.delay_s == 0.0);
}

TEST_CASE("A tuning keeps the least margins until a delay takes the phase margin below 30 degrees",
          "[control][margins]") {
  // Rigid at 1 kHz, 40 Hz: the rule's margin less the hold's ωT/2 (about
  // 38.4°). A delay τ takes 360·f_c·τ degrees more at the crossover f_c:
  // 0.3 ms about 4.4° (kept), 1 ms about 14.6° (below 30°).
  const PidGains gains = tune_pid(15.0, 40.0);
  const double period_s = 1e-3;
  const LoopMargins rigid = loop_margins(gains, period_s, PlantModel{.mass_kg = 15.0});
  const double expected_rigid = rule_margin_deg() - 360.0 * rigid.crossover_Hz * period_s / 2.0;
  CHECK(rigid.phase_margin_deg == Approx(expected_rigid).margin(1.0));
  CHECK(margin_shortfall(gains, period_s, PlantModel{.mass_kg = 15.0}).empty());
  const PlantModel short_delay{.mass_kg = 15.0, .delay_s = 3e-4};
  INFO("0.3 ms: " << margin_shortfall(gains, period_s, short_delay));
  CHECK(expected_rigid - 360.0 * rigid.crossover_Hz * 3e-4 > kMinPhaseMargin_deg + 1.0);
  CHECK(margin_shortfall(gains, period_s, short_delay).empty());
  const PlantModel long_delay{.mass_kg = 15.0, .delay_s = 1e-3};
  CHECK(expected_rigid - 360.0 * rigid.crossover_Hz * 1e-3 < kMinPhaseMargin_deg - 1.0);
  const std::string shortfall = margin_shortfall(gains, period_s, long_delay);
  INFO("1 ms: " << shortfall);
  CHECK(shortfall.rfind("short of the least margins (phase margin ", 0) == 0);
  CHECK(shortfall.find(", at least 30;") != std::string::npos);
  CHECK(shortfall.find("gain margin ") != std::string::npos);
  // The gain margin alone: the tuning rule's loop scaled to leave less than 6 dB.
  const LoopMargins m = loop_margins(gains, period_s, PlantModel{.mass_kg = 15.0});
  PidGains louder = gains;
  const double scale = std::pow(10.0, (m.gain_margin_dB - 4.0) / 20.0);  // 4 dB left
  louder.proportional_N_per_m *= scale;
  louder.integral_N_per_m_s *= scale;
  louder.derivative_N_s_per_m *= scale;
  const std::string gain_short = margin_shortfall(louder, period_s, PlantModel{.mass_kg = 15.0});
  INFO("gains x" << scale << ": " << gain_short);
  CHECK(gain_short.find("gain margin 4.0 dB") != std::string::npos);
}

namespace {

/// The loop run in time, independently of the frequency responses: the
/// PidController at 1 kHz on the two-mass plant (RK4 in 10 µs substeps), the
/// force through a first-order current loop and a pure delay, the encoder on
/// the far mass. From a 1 µm step of the reference: the largest |error| over
/// the last of 3 s against the step.
double settled_error_ratio(const PidGains& gains, const PlantModel& plant) {
  const double period_s = 1e-3, h = 1e-5, fraction = 0.3, m = plant.mass_kg;
  const int substeps = 100, delay_substeps = static_cast<int>(std::lround(plant.delay_s / h));
  const double m1 = (1 - fraction) * m, m2 = fraction * m, mu = m1 * m2 / m, w = 2 * kPiRad * plant.mode_frequency_Hz;
  const double k = w * w * mu, c = 2 * plant.mode_damping_ratio * w * mu;
  const double wc = 2 * kPiRad * plant.current_loop_bandwidth_Hz;
  Eigen::Vector4d x = Eigen::Vector4d::Zero();  // x₁, v₁, x₂, v₂
  const auto derivative = [&](const Eigen::Vector4d& s, double force) {
    const double spring = k * (s(0) - s(2)) + c * (s(1) - s(3));
    return Eigen::Vector4d(s(1), (force - spring) / m1, s(3), spring / m2);
  };
  PidController pid(gains, period_s);
  std::vector<double> in_flight(static_cast<std::size_t>(delay_substeps) + 1, 0.0);
  double force = 0.0, command = 0.0, worst = 0.0;
  const double step = 1e-6;
  const int cycles = 3000;
  for (int n = 0; n < cycles; ++n) {
    command = pid.update(step - x(2));
    for (int j = 0; j < substeps; ++j) {
      in_flight.insert(in_flight.begin(), command);
      const double demand = in_flight.back();
      in_flight.pop_back();
      force += wc > 0.0 ? (demand - force) * (1.0 - std::exp(-wc * h)) : demand - force;
      const Eigen::Vector4d k1 = derivative(x, force), k2 = derivative(x + h / 2 * k1, force),
                            k3 = derivative(x + h / 2 * k2, force), k4 = derivative(x + h * k3, force);
      x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    if (!std::isfinite(x(2))) return std::numeric_limits<double>::infinity();
    if (n >= cycles - 1000) worst = std::max(worst, std::abs(step - x(2)));
  }
  return worst / step;
}

}  // namespace

TEST_CASE("The stability verdict agrees with the loop run in time: a mode below the crossover destabilises it",
          "[control][margins]") {
  const PlantModel plant{.mass_kg = 15.0, .mode_frequency_Hz = 270.0, .mode_damping_ratio = 0.02,
                         .current_loop_bandwidth_Hz = 1350.0, .delay_s = 2.7e-4};
  for (const double bandwidth_hz : {40.0, 130.0}) {
    const PidGains gains = tune_pid(15.0, bandwidth_hz);
    const LoopMargins m = loop_margins(gains, 1e-3, plant);
    const double ratio = settled_error_ratio(gains, plant);
    INFO(bandwidth_hz << " Hz: net crossings " << m.real_axis_crossings << ", phase margin " << m.phase_margin_deg
                      << " deg; |error| over the last second " << ratio << " x the step");
    if (bandwidth_hz == 40.0) {
      CHECK(m.stable());
      CHECK(ratio < 0.01);  // settled: a 40 Hz loop's error decays in a few tens of ms
      CHECK(margin_shortfall(gains, 1e-3, plant).empty());
    } else {
      CHECK_FALSE(m.stable());
      CHECK(ratio > 100.0);  // grown from the step by orders of magnitude
      CHECK(margin_shortfall(gains, 1e-3, plant).rfind("unstable (", 0) == 0);
    }
  }
}
