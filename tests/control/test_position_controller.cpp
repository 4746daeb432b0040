// PID tuning and discretisation checked on a simulated discrete mass,
// the eq. (40) feedforward, its least-squares identification, finite-difference
// reference derivatives, and the combined position controller.
#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "daemon/control/position_controller.hpp"
#include "daemon/control/trajectory.hpp"
#include "support/allocation_counter.hpp"

using namespace clm::control;
using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

namespace {

constexpr double kPi = std::numbers::pi;

/// A rigid mass driven by a force held constant over each period (exact ZOH
/// solution of m·ÿ = F).
struct DiscreteMass {
  double mass_kg;
  double period_s;
  double position_m = 0.0;
  double velocity_m_per_s = 0.0;
  void step(double force_N) {
    position_m += period_s * velocity_m_per_s + period_s * period_s / (2 * mass_kg) * force_N;
    velocity_m_per_s += period_s * force_N / mass_kg;
  }
};

/// Phasor (complex amplitude) of `signal` at ω by least squares on
/// [sin ωt, cos ωt, 1, t] (offset and drift removed).
std::complex<double> phasor(const std::vector<double>& time_s, const std::vector<double>& signal, double omega) {
  const auto n = static_cast<Eigen::Index>(signal.size());
  Eigen::MatrixXd basis(n, 4);
  Eigen::VectorXd values(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = time_s[static_cast<std::size_t>(i)];
    basis.row(i) << std::sin(omega * t), std::cos(omega * t), 1.0, t;
    values(i) = signal[static_cast<std::size_t>(i)];
  }
  const Eigen::Vector4d fit = basis.colPivHouseholderQr().solve(values);
  return {fit(0), fit(1)};
}

/// Open-loop gain L = C·P of PidController on the discrete mass at `frequency_hz`,
/// measured in closed loop: a sine d is added to the controller output u_c,
/// u = u_c + d drives the mass, and L = −u_c/u.
std::complex<double> measured_loop_gain(const PidGains& gains, double mass_kg, double period_s, double frequency_hz) {
  PidController pid(gains, period_s);
  DiscreteMass plant{mass_kg, period_s};
  const double omega = 2 * kPi * frequency_hz;
  const int settle = static_cast<int>(1.0 / period_s);
  const int measure = static_cast<int>(std::ceil(std::max(1.0, 20.0 / frequency_hz) / period_s));
  std::vector<double> time_s, controller_N, total_N;
  for (int k = 0; k < settle + measure; ++k) {
    const double t = k * period_s;
    const double controller = pid.update(0.0 - plant.position_m);
    const double total = controller + std::sin(omega * t);
    plant.step(total);
    if (k >= settle) {
      time_s.push_back(t);
      controller_N.push_back(controller);
      total_N.push_back(total);
    }
  }
  return -phasor(time_s, controller_N, omega) / phasor(time_s, total_N, omega);
}

/// Frequency [Hz] where the measured |L| crosses 1 (bisection in log frequency).
double measured_crossover_hz(const PidGains& gains, double mass_kg, double period_s, double guess_hz) {
  double lo = guess_hz / 3, hi = guess_hz * 3;
  for (int i = 0; i < 30; ++i) {
    const double mid = std::sqrt(lo * hi);
    (std::abs(measured_loop_gain(gains, mass_kg, period_s, mid)) > 1.0 ? lo : hi) = mid;
  }
  return std::sqrt(lo * hi);
}

double phase_margin_deg(std::complex<double> loop_gain) { return 180.0 + std::arg(loop_gain) * 180.0 / kPi; }

}  // namespace

// ---------------------------------------------------------------------------
// Tuning and PID

TEST_CASE("tune_pid: the continuous loop crosses 0 dB at the bandwidth with >= 30 deg phase margin", "[pid]") {
  for (const double mass_kg : {0.5, 10.0, 80.0}) {
    for (const double bandwidth_hz : {10.0, 50.0, 200.0}) {
      const PidGains g = tune_pid(mass_kg, bandwidth_hz);
      const double w = 2 * kPi * bandwidth_hz;
      const std::complex<double> s(0.0, w);
      // C(s) = (kp + ki/s + kd s)/(s/ω_lp + 1), P(s) = 1/(m s²), as documented.
      const std::complex<double> c = (g.proportional_N_per_m + g.integral_N_per_m_s / s + g.derivative_N_s_per_m * s) /
                                     (s / (2 * kPi * g.lowpass_hz) + 1.0);
      const std::complex<double> loop = c / (mass_kg * s * s);
      CHECK_THAT(std::abs(loop), WithinRel(1.0, 1e-12));
      CHECK(phase_margin_deg(loop) >= 30.0);
      CHECK_THAT(phase_margin_deg(loop), WithinAbs(45.6, 0.1));
      // Integrator corner well below, low-pass well above the crossover.
      CHECK_THAT(g.integral_N_per_m_s / g.proportional_N_per_m, WithinRel(w / 5, 1e-12));
      CHECK_THAT(g.lowpass_hz, WithinRel(5 * bandwidth_hz, 1e-12));
    }
  }
  REQUIRE_THROWS_WITH(tune_pid(0.0, 50.0), Contains("mass_kg"));
  REQUIRE_THROWS_WITH(tune_pid(10.0, -1.0), Contains("bandwidth_hz") && Contains("-1"));
  // Finite inputs whose gains overflow (k_p ≈ 0.557·m·(2π·f)² > 1.8e308) are refused, not returned as inf.
  REQUIRE_THROWS_WITH(tune_pid(1e308, 40.0), Contains("mass_kg 1e+308 kg") && Contains("non-finite gains"));
  REQUIRE_THROWS_WITH(tune_pid(1e300, 3000.0), Contains("non-finite gains"));
}

TEST_CASE("PID on a simulated discrete mass: measured crossover at the target bandwidth, phase margin >= 30 deg",
          "[pid][simulation]") {
  const double mass_kg = 10.0;
  const double bandwidth_hz = 50.0;
  const PidGains gains = tune_pid(mass_kg, bandwidth_hz);
  SECTION("10 kHz sampling: close to continuous time") {
    const double crossover_hz = measured_crossover_hz(gains, mass_kg, 1e-4, bandwidth_hz);
    CHECK_THAT(crossover_hz, WithinRel(bandwidth_hz, 0.02));
    const double margin_deg = phase_margin_deg(measured_loop_gain(gains, mass_kg, 1e-4, crossover_hz));
    // 45.6° continuous minus about ω_c·T_s/2 = 0.9° for the hold.
    CHECK(margin_deg > 40.0);
    CHECK(margin_deg < 46.0);
  }
  SECTION("1 kHz sampling: the hold costs about w_c T_s / 2 = 9 deg, margin still >= 30 deg") {
    const double crossover_hz = measured_crossover_hz(gains, mass_kg, 1e-3, bandwidth_hz);
    CHECK_THAT(crossover_hz, WithinRel(bandwidth_hz, 0.05));
    const double margin_deg = phase_margin_deg(measured_loop_gain(gains, mass_kg, 1e-3, crossover_hz));
    CHECK(margin_deg > 30.0);
    CHECK(margin_deg < 40.0);
  }
}

TEST_CASE("PID on a simulated discrete mass follows a step with bounded overshoot and no steady error",
          "[pid][simulation]") {
  const double mass_kg = 10.0, period_s = 1e-4, step_m = 1e-3;
  const PidGains gains = tune_pid(mass_kg, 50.0);
  PidController pid(gains, period_s);
  DiscreteMass plant{mass_kg, period_s};
  double peak_m = 0.0;
  double worst_after_settling_m = 0.0;
  for (int k = 0; k < 10000; ++k) {
    plant.step(pid.update(step_m - plant.position_m));
    peak_m = std::max(peak_m, plant.position_m);
    // Five periods of the bandwidth after the step the error is within 2 %.
    if ((k + 1) * period_s >= 0.1) worst_after_settling_m = std::max(worst_after_settling_m, std::abs(step_m - plant.position_m));
  }
  const double overshoot = peak_m / step_m - 1.0;
  // A 45° phase margin with integral action (type-3 loop) overshoots by
  // roughly 40 %; bound it well below an underdamped loop's.
  CHECK(overshoot > 0.0);
  CHECK(overshoot < 0.5);
  CHECK(worst_after_settling_m < 0.02 * step_m);
  CHECK(std::abs(step_m - plant.position_m) < 1e-9 * step_m);
}

TEST_CASE("PID rejects a constant force disturbance through its integrator", "[pid][simulation]") {
  const double mass_kg = 10.0, period_s = 1e-4;
  PidController pid(tune_pid(mass_kg, 50.0), period_s);
  DiscreteMass plant{mass_kg, period_s};
  for (int k = 0; k < 20000; ++k) plant.step(pid.update(0.0 - plant.position_m) + 25.0);
  CHECK(std::abs(plant.position_m) < 1e-12);
  CHECK_THAT(pid.output_N(), WithinAbs(-25.0, 1e-6));
}

TEST_CASE("Tustin PID: a constant error gives kp e + ki e t lagged by the low-pass time constant", "[pid]") {
  const PidGains gains{1000.0, 20000.0, 30.0, 200.0};
  const double period_s = 1e-3, error_m = 0.002;
  PidController pid(gains, period_s);
  const double tau_s = 1.0 / (2 * kPi * gains.lowpass_hz);
  double output_N = 0.0;
  const int samples = 400;
  for (int k = 0; k < samples; ++k) output_N = pid.update(error_m);
  // Bumpless start: the error is taken as present one sample before the first
  // update, so after k+1 updates the trapezoidal integral is ki·e·(k+1)·T_s; the
  // Tustin low-pass delays a ramp by exactly 1/ω_lp; no derivative output.
  const double expected_N = gains.proportional_N_per_m * error_m +
                            gains.integral_N_per_m_s * error_m * (samples * period_s - tau_s);
  CHECK_THAT(output_N, WithinRel(expected_N, 1e-9));
  CHECK_THAT(pid.integrator_N(), WithinRel(gains.integral_N_per_m_s * error_m * samples * period_s, 1e-12));
}

TEST_CASE("Tustin PID: a ramp error gives kd times the slope from the derivative path", "[pid]") {
  const PidGains gains{1000.0, 0.0, 30.0, 200.0};
  const double period_s = 1e-3, slope_m_per_s = 0.01;
  PidController pid(gains, period_s);
  const double tau_s = 1.0 / (2 * kPi * gains.lowpass_hz);
  double output_N = 0.0;
  const int samples = 400;
  pid.update(0.0);
  for (int k = 1; k <= samples; ++k) output_N = pid.update(slope_m_per_s * k * period_s);
  const double expected_N = gains.proportional_N_per_m * slope_m_per_s * (samples * period_s - tau_s) +
                            gains.derivative_N_s_per_m * slope_m_per_s;
  CHECK_THAT(output_N, WithinRel(expected_N, 1e-9));
}

TEST_CASE("PID anti-windup limits the integrator and reset() restores the fresh controller", "[pid]") {
  const PidGains gains{1000.0, 20000.0, 30.0, 200.0};
  PidController pid(gains, 1e-3);
  pid.set_integrator_limit_N(5.0);
  double output_N = 0.0;
  for (int k = 0; k < 1000; ++k) output_N = pid.update(0.01);
  CHECK(pid.integrator_N() == 5.0);
  CHECK(pid.integrator_limited());
  CHECK_THAT(output_N, WithinRel(gains.proportional_N_per_m * 0.01 + 5.0, 1e-12));
  // Recovers at once when the error changes sign (no wound-up state); the
  // first trapezoid (e_k + e_{k−1}) = 0, the second integrates down.
  pid.update(-0.01);
  pid.update(-0.01);
  CHECK_THAT(pid.integrator_N(), WithinRel(5.0 - 20000.0 * 0.01 * 1e-3, 1e-12));
  CHECK_FALSE(pid.integrator_limited());

  PidController fresh(gains, 1e-3);
  fresh.set_integrator_limit_N(5.0);
  pid.reset();
  for (int k = 0; k < 50; ++k) {
    const double e = 1e-3 * std::sin(0.3 * k);
    REQUIRE(pid.update(e) == fresh.update(e));
  }
  REQUIRE_THROWS_WITH(pid.set_integrator_limit_N(0.0), Contains("integrator limit") && Contains("0"));
  REQUIRE_THROWS_WITH(PidController(gains, 0.0), Contains("period_s"));
  REQUIRE_THROWS_WITH(PidController({1, 1, 1, 0.0}, 1e-3), Contains("lowpass_hz"));
  REQUIRE_THROWS_WITH(PidController({-1, 1, 1, 10}, 1e-3), Contains("proportional_N_per_m") && Contains("-1"));
}

// ---------------------------------------------------------------------------
// Feedforward

TEST_CASE("feedforward reproduces eq. (40) with delta = (z+1)/2 and sign(0) = 0", "[feedforward]") {
  const FeedforwardParameters p{12.0, 40.0, 6.0};
  const ReferenceSample now{0.0, 0.1, 0.5, 0.0};
  const ReferenceSample next{0.0, 0.3, 1.5, 0.0};
  // 12·(0.5+1.5)/2 + 40·(0.1+0.3)/2 + 6·(1+1)/2
  CHECK_THAT(feedforward_force_N(p, now, next), WithinAbs(12.0 + 8.0 + 6.0, 1e-12));
  // Starting from rest: sign(0) = 0, so only half the Coulomb force.
  const ReferenceSample rest{0.0, 0.0, 0.0, 0.0};
  const ReferenceSample leaving{0.0, -0.002, -1.0, 0.0};
  CHECK_THAT(feedforward_force_N(p, rest, leaving), WithinAbs(12.0 * -0.5 + 40.0 * -0.001 + 6.0 * -0.5, 1e-12));
  CHECK(feedforward_force_N(p, rest, rest) == 0.0);
}

namespace {

struct SampledReference {
  std::vector<double> time_s;
  std::vector<double> position_m;
  std::vector<ReferenceSample> exact;
};

SampledReference sample_program(const MoveProgram& program, double period_s) {
  SampledReference r;
  const auto n = static_cast<std::size_t>(program.duration_s() / period_s) + 1;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * period_s;
    r.time_s.push_back(t);
    r.exact.push_back(program.sample(t));
    r.position_m.push_back(r.exact.back().position_m);
  }
  return r;
}

std::vector<double> synthetic_force(const FeedforwardParameters& p, const std::vector<ReferenceSample>& reference) {
  std::vector<double> force(reference.size());
  for (std::size_t k = 0; k + 1 < reference.size(); ++k) force[k] = feedforward_force_N(p, reference[k], reference[k + 1]);
  force.back() = 1e6;  // the last sample has no successor and must not be used
  return force;
}

}  // namespace

TEST_CASE("identify_feedforward recovers m, f_v, f_c exactly from noise-free data on the Fig. 8 reference",
          "[feedforward][identification]") {
  const FeedforwardParameters truth{12.3, 45.6, 7.8};
  const SampledReference r = sample_program(fig8_program(), 1e-3);
  const FeedforwardParameters fit = identify_feedforward(r.exact, synthetic_force(truth, r.exact));
  CHECK_THAT(fit.mass_kg, WithinRel(truth.mass_kg, 1e-9));
  CHECK_THAT(fit.viscous_N_s_per_m, WithinRel(truth.viscous_N_s_per_m, 1e-9));
  CHECK_THAT(fit.coulomb_N, WithinRel(truth.coulomb_N, 1e-9));
}

TEST_CASE("identify_feedforward is within 1 % with force noise of 0.5 N rms", "[feedforward][identification]") {
  const FeedforwardParameters truth{12.3, 45.6, 7.8};
  const SampledReference r = sample_program(fig8_program(), 1e-3);
  std::vector<double> force = synthetic_force(truth, r.exact);
  std::mt19937_64 rng(42);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (double& f : force) f += noise(rng);
  const FeedforwardParameters fit = identify_feedforward(r.exact, force);
  CHECK_THAT(fit.mass_kg, WithinRel(truth.mass_kg, 0.01));
  CHECK_THAT(fit.viscous_N_s_per_m, WithinRel(truth.viscous_N_s_per_m, 0.01));
  CHECK_THAT(fit.coulomb_N, WithinRel(truth.coulomb_N, 0.01));
}

TEST_CASE("identify_feedforward on derivatives from sampled positions only (CSV t_s, r_m) is within 1 %",
          "[feedforward][identification]") {
  const FeedforwardParameters truth{12.3, 45.6, 7.8};
  const SampledReference r = sample_program(fig8_program(), 1e-3);
  const std::vector<ReferenceSample> derived = reference_from_positions(r.time_s, r.position_m);
  const FeedforwardParameters fit = identify_feedforward(derived, synthetic_force(truth, r.exact));
  CHECK_THAT(fit.mass_kg, WithinRel(truth.mass_kg, 0.01));
  CHECK_THAT(fit.viscous_N_s_per_m, WithinRel(truth.viscous_N_s_per_m, 0.01));
  CHECK_THAT(fit.coulomb_N, WithinRel(truth.coulomb_N, 0.01));
}

TEST_CASE("fit_feedforward's standard errors match the spread over noise seeds and flag what the data do not excite",
          "[feedforward][identification]") {
  const FeedforwardParameters truth{12.3, 45.6, 7.8};
  const SampledReference r = sample_program(fig8_program(), 1e-3);
  const auto fits_with_noise = [&](double noise_N, int seeds) {
    std::vector<FeedforwardFit> fits;
    for (int seed = 0; seed < seeds; ++seed) {
      std::vector<double> force = synthetic_force(truth, r.exact);
      std::mt19937_64 rng(100 + seed);
      std::normal_distribution<double> noise(0.0, noise_N);
      for (double& f : force) f += noise(rng);
      fits.push_back(fit_feedforward(r.exact, force));
    }
    return fits;
  };
  // The reported standard error of m against the spread of m over 40 seeds
  // (independent white noise, so the two agree up to sampling).
  const auto fits = fits_with_noise(5.0, 40);
  double mean = 0.0, square = 0.0;
  for (const auto& fit : fits) mean += fit.parameters.mass_kg / fits.size();
  for (const auto& fit : fits) square += std::pow(fit.parameters.mass_kg - mean, 2) / (fits.size() - 1);
  const double spread = std::sqrt(square);
  CHECK(fits[0].standard_error.mass_kg == Approx(spread).epsilon(0.35));
  CHECK(fits[0].residual_rms_N == Approx(5.0).epsilon(0.05));
  CHECK(fits[0].condition >= 1.0);
  CHECK(fits[0].samples == r.exact.size() - 1);
  // 0.5 N of noise: every parameter excited. 300 N: the short accelerations of
  // Fig. 8 no longer pin the mass.
  CHECK(unexcited_parameters(fits_with_noise(0.5, 1)[0]).empty());
  const auto noisy = unexcited_parameters(fits_with_noise(300.0, 1)[0]);
  CHECK(std::find(noisy.begin(), noisy.end(), "mass_kg") != noisy.end());
}

TEST_CASE("identify_feedforward names the reason when the data cannot determine the parameters",
          "[feedforward][identification]") {
  std::vector<ReferenceSample> still(100);
  std::vector<double> force(100, 1.0);
  REQUIRE_THROWS_WITH(identify_feedforward(still, force), Contains("never moves"));
  REQUIRE_THROWS_WITH(identify_feedforward(std::span(still).first(2), std::span(force).first(2)),
                      Contains("at least 3") && Contains("got 2"));
  REQUIRE_THROWS_WITH(identify_feedforward(still, std::span(force).first(99)), Contains("100") && Contains("99"));

  std::vector<ReferenceSample> constant_velocity(100);
  for (std::size_t k = 0; k < 100; ++k) constant_velocity[k] = {0.1 * static_cast<double>(k), 0.1, 0.0, 0.0};
  REQUIRE_THROWS_WITH(identify_feedforward(constant_velocity, force), Contains("never accelerates"));

  // Accelerating, but the velocity never changes sign and sgn(v) ∝ v: positive
  // velocity constant except for an acceleration signal that does not move it.
  std::vector<ReferenceSample> collinear(100);
  for (std::size_t k = 0; k < 100; ++k) collinear[k] = {0.0, 0.2, std::sin(0.1 * static_cast<double>(k)), 0.0};
  REQUIRE_THROWS_WITH(identify_feedforward(collinear, force), Contains("rank-deficient"));

  std::vector<double> bad_force(100, 1.0);
  bad_force[17] = std::numeric_limits<double>::quiet_NaN();
  const SampledReference r = sample_program(fig8_program_at(0.15), 0.03);
  REQUIRE_THROWS_WITH(identify_feedforward(std::span(r.exact).first(100), bad_force), Contains("force_demand_N[17]"));
}

// ---------------------------------------------------------------------------
// Derivatives from sampled positions

TEST_CASE("reference_from_positions is exact for a quadratic on a non-uniform grid", "[reference]") {
  std::vector<double> t, r;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> step(0.5e-3, 1.5e-3);
  double time = 0.2;
  for (int i = 0; i < 200; ++i) {
    t.push_back(time);
    r.push_back(0.03 + 0.4 * time - 1.7 * time * time);
    time += step(rng);
  }
  const std::vector<ReferenceSample> d = reference_from_positions(t, r);
  REQUIRE(d.size() == t.size());
  for (std::size_t i = 0; i < d.size(); ++i) {
    INFO("i = " << i);
    REQUIRE(d[i].position_m == r[i]);
    REQUIRE_THAT(d[i].velocity_m_per_s, WithinAbs(0.4 - 3.4 * t[i], 1e-9));
    REQUIRE_THAT(d[i].acceleration_m_per_s2, WithinAbs(-3.4, 1e-6));
    REQUIRE_THAT(d[i].jerk_m_per_s3, WithinAbs(0.0, 1e-4));
  }
}

TEST_CASE("reference_from_positions on a cubic has the documented O(h^2) errors", "[reference]") {
  const double c = 2.0, h = 1e-2;  // r = c t³, r⃛ = 6c
  std::vector<double> t, r;
  for (int i = 0; i < 50; ++i) {
    t.push_back(i * h);
    r.push_back(c * t.back() * t.back() * t.back());
  }
  const std::vector<ReferenceSample> d = reference_from_positions(t, r);
  const std::size_t n = d.size();
  for (std::size_t i = 1; i + 1 < n; ++i) {
    // Central: ((t+h)³ − (t−h)³)/(2h) = 3t² + h²; second difference exact.
    REQUIRE_THAT(d[i].velocity_m_per_s, WithinAbs(3 * c * t[i] * t[i] + c * h * h, 1e-10));
    REQUIRE_THAT(d[i].acceleration_m_per_s2, WithinAbs(6 * c * t[i], 1e-8));
  }
  for (std::size_t i = 2; i + 2 < n; ++i) REQUIRE_THAT(d[i].jerk_m_per_s3, WithinAbs(6 * c, 1e-6));
  // Ends: one-sided, velocity error −h²/3·r⃛ = −2c h², acceleration off by h·r⃛.
  CHECK_THAT(d[0].velocity_m_per_s, WithinAbs(-2 * c * h * h, 1e-10));
  CHECK_THAT(d[n - 1].velocity_m_per_s, WithinAbs(3 * c * t[n - 1] * t[n - 1] - 2 * c * h * h, 1e-9));
  CHECK_THAT(d[0].acceleration_m_per_s2, WithinAbs(6 * c * t[0] + 6 * c * h, 1e-8));
  CHECK_THAT(d[n - 1].acceleration_m_per_s2, WithinAbs(6 * c * t[n - 1] - 6 * c * h, 1e-8));
}

TEST_CASE("reference_from_positions on a jerk-limited move stays within the documented bounds", "[reference]") {
  const MotionLimits limits{0.15, 1.0, 1000.0};
  const ThirdOrderMove move = ThirdOrderMove::plan(-0.1, 0.1, limits);
  const double h = 1e-3;
  std::vector<double> t, r;
  for (double time = -0.05; time < move.duration_s() + 0.05; time += h) {
    t.push_back(time);
    r.push_back(move.sample(time).position_m);
  }
  const std::vector<ReferenceSample> d = reference_from_positions(t, r);
  for (std::size_t i = 0; i < d.size(); ++i) {
    const ReferenceSample exact = move.sample(t[i]);
    REQUIRE(std::abs(d[i].velocity_m_per_s - exact.velocity_m_per_s) <= limits.jerk_m_per_s3 * h * h / 3 + 1e-12);
    REQUIRE(std::abs(d[i].acceleration_m_per_s2 - exact.acceleration_m_per_s2) <= limits.jerk_m_per_s3 * h + 1e-8);
  }
}

TEST_CASE("reference_from_positions rejects bad input by index", "[reference]") {
  const std::vector<double> t{0.0, 0.001, 0.001, 0.003};
  const std::vector<double> r{0.0, 0.0, 0.0, 0.0};
  REQUIRE_THROWS_WITH(reference_from_positions(t, r), Contains("t_s[2]") && Contains("strictly increase"));
  REQUIRE_THROWS_WITH(reference_from_positions(std::span(t).first(2), std::span(r).first(2)), Contains("at least 3"));
  REQUIRE_THROWS_WITH(reference_from_positions(t, std::span(r).first(3)), Contains("4") && Contains("3"));
  const std::vector<double> r_nan{0.0, std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0};
  const std::vector<double> t_ok{0.0, 0.001, 0.002, 0.003};
  REQUIRE_THROWS_WITH(reference_from_positions(t_ok, r_nan), Contains("sample 1"));
}

// ---------------------------------------------------------------------------
// Position controller

TEST_CASE("PositionController output is PID(r - y) plus the eq. (40) feedforward of the reference ahead",
          "[position_controller]") {
  const PidGains gains = tune_pid(8.0, 40.0);
  const FeedforwardParameters ff{8.0, 20.0, 3.0};
  const double period_s = 2e-4, lead_s = 3e-4;
  PositionController controller(gains, ff, period_s);
  PidController pid(gains, period_s);
  const MoveProgram program = fig8_program_at(0.075);
  for (int k = 0; k < 5000; ++k) {
    const ReferenceSample now = program.sample(k * period_s);
    const ReferenceSample ahead = program.sample(k * period_s + lead_s);
    const ReferenceSample ahead_next = program.sample((k + 1) * period_s + lead_s);
    const double measured_m = now.position_m - 1e-5 * std::sin(0.01 * k);
    const double demand_N = controller.update(now, measured_m, ahead, ahead_next);
    const double feedback_N = pid.update(now.position_m - measured_m);
    const double feedforward_N = feedforward_force_N(ff, ahead, ahead_next);
    REQUIRE(controller.last_feedback_N() == feedback_N);
    REQUIRE(controller.last_feedforward_N() == feedforward_N);
    REQUIRE(demand_N == feedback_N + feedforward_N);
    REQUIRE(controller.last_error_m() == now.position_m - measured_m);
  }
  controller.set_feedforward({0.0, 0.0, 0.0});
  const double demand_N =
      controller.update(program.sample(1.0), 0.0, program.sample(1.0), program.sample(1.0 + period_s));
  CHECK(demand_N == controller.last_feedback_N());
  CHECK(controller.last_feedforward_N() == 0.0);

  controller.reset();
  PidController fresh(gains, period_s);
  CHECK(controller.update({0.01, 0, 0, 0}, 0.0, {0.01, 0, 0, 0}, {0.01, 0, 0, 0}) == fresh.update(0.01));
  REQUIRE_THROWS_WITH(PositionController(gains, {std::numeric_limits<double>::infinity(), 0, 0}, period_s),
                      Contains("mass_kg"));
}

TEST_CASE("feedforward with the true mass cuts the tracking error on a simulated mass by orders of magnitude",
          "[position_controller][simulation]") {
  const double mass_kg = 10.0, period_s = 1e-4;
  const PidGains gains = tune_pid(mass_kg, 50.0);
  const MoveProgram program = fig8_program_at(0.15);
  const auto track = [&](double feedforward_mass_kg) {
    PositionController controller(gains, {feedforward_mass_kg, 0.0, 0.0}, period_s);
    DiscreteMass plant{mass_kg, period_s, program.start_m()};
    double worst_m = 0.0;
    const int samples = static_cast<int>(program.duration_s() / period_s) + 100;
    for (int k = 0; k < samples; ++k) {
      const ReferenceSample now = program.sample(k * period_s);
      plant.step(controller.update(now, plant.position_m, now, program.sample((k + 1) * period_s)));
      worst_m = std::max(worst_m, std::abs(program.sample((k + 1) * period_s).position_m - plant.position_m));
    }
    return worst_m;
  };
  const double without_m = track(0.0);
  const double with_m = track(mass_kg);
  // Without feedforward the loop needs an error of about m·a/|C| to push the
  // mass; with it only the residual of the ZOH/average mismatch j·T_s³/12 per
  // sample around the jerk switches remains.
  CHECK(without_m > 1e-6);
  CHECK(with_m < 1e-8);
  CHECK(with_m < without_m / 1000);
}

TEST_CASE("PositionController::update and PidController::update do not allocate over 1e5 calls",
          "[position_controller][allocation]") {
  const double period_s = 1e-4;
  PositionController controller(tune_pid(10.0, 50.0), {10.0, 5.0, 1.0}, period_s);
  const MoveProgram program = fig8_program();
  DiscreteMass plant{10.0, period_s, program.start_m()};
  PidController pid(tune_pid(10.0, 50.0), period_s);
  pid.set_integrator_limit_N(100.0);
  double sum = 0.0;
  clm::test::AllocationScope scope;
  for (int k = 0; k < 100000; ++k) {
    const ReferenceSample now = program.sample(k * period_s);
    const double force_N = controller.update(now, plant.position_m, now, program.sample((k + 1) * period_s));
    plant.step(force_N);
    sum += pid.update(1e-6 * (k % 7));
  }
  REQUIRE(scope.allocations() == 0);
  REQUIRE(std::isfinite(sum));
  REQUIRE(std::isfinite(plant.position_m));
}
