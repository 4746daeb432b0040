// The position loop's margins (daemon/control/loop_analysis.hpp) against
// the analytic phase margin of the tuning rule, the zero-order hold's and a
// delay's phase lag, an independent state-space solution of the two-mass
// plant, and the gain margin's own definition.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <cmath>
#include <complex>

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
