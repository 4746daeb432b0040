#include "support/position_only_motor.hpp"

#include <algorithm>
#include <cmath>

#include "commutation/classical.hpp"

namespace clm::test {

PositionOnlyMotor::PositionOnlyMotor(std::mt19937_64& rng, double motor_constant_N_per_A, double phase_offset_rad) {
  std::uniform_real_distribution<double> gain(-3.0, 3.0), cogging(-2.0, 2.0);
  CoilGain a, b;
  classical_physics_parameters({motor_constant_N_per_A, phase_offset_rad, 0.0, 0.0}, a, b);
  model.a_y << a(0, 0), a(0, 1);
  model.b_y << b(0, 0), b(0, 1);
  const int n = basis.size();
  model.column_a = Eigen::RowVectorXd::NullaryExpr(n, [&] { return gain(rng); });
  model.column_b = Eigen::RowVectorXd::NullaryExpr(n, [&] { return gain(rng); });
  model.cogging = Eigen::RowVectorXd::NullaryExpr(n, [&] { return cogging(rng); });
}

double PositionOnlyMotor::force_N(double position_m, const Eigen::Vector2d& currents_A) const {
  return model.gain(position_m, kPolePitch_m, basis).dot(currents_A.transpose()) + model.cogging_N(position_m, basis);
}

identification::MotionRun PositionOnlyMotor::run(double delta_rad, double seconds, double phase,
                                                 std::vector<double>* magnitude_N) const {
  const auto samples = static_cast<Eigen::Index>(seconds / kPeriod_s);
  identification::MotionRun out;
  out.time_s.resize(samples);
  out.position_m.resize(samples);
  out.currents_A.resize(2, samples);
  std::vector<double> magnitude(static_cast<std::size_t>(samples));
  double y = 0.0, v = 0.0, previous_measured = 0.0;
  double applied = 0.0;  // the magnitude the current loop has reached
  const double h = kPeriod_s / kSubsteps;
  const auto reference = [&](double t, int derivative) {
    const double w1 = 2.0 * kPi * 0.7, w2 = 2.0 * kPi * 2.3;
    const double a1 = 0.05, a2 = 0.006;
    const double s1 = std::pow(w1, derivative) * a1, s2 = std::pow(w2, derivative) * a2;
    const auto f = [&](double w, double p) {
      return derivative == 0 ? std::sin(w * t + p) : derivative == 1 ? std::cos(w * t + p) : -std::sin(w * t + p);
    };
    return s1 * f(w1, phase) + s2 * f(w2, 2.0 * phase);
  };
  for (Eigen::Index k = 0; k < samples; ++k) {
    const double t = static_cast<double>(k) * kPeriod_s;
    const double measured = std::round(y / 1e-7) * 1e-7;
    out.time_s[k] = t;
    out.position_m[k] = measured;
    const double velocity = k > 0 ? (measured - previous_measured) / kPeriod_s : 0.0;
    previous_measured = measured;
    const double demand =
        10.0 * reference(t, 2) + 2e5 * (reference(t, 0) - measured) + 2e3 * (reference(t, 1) - velocity);
    magnitude[static_cast<std::size_t>(k)] = demand;
    for (int step = 0; step < kSubsteps; ++step) {
      // The setpoint in effect after the delay, and the lag's mean over the substep.
      const Eigen::Index in_effect = step >= delay_substeps ? k : std::max<Eigen::Index>(k - 1, 0);
      const double target = magnitude[static_cast<std::size_t>(in_effect)];
      double mean = target;
      if (current_loop_Hz > 0.0) {
        const double decay = std::exp(-2.0 * kPi * current_loop_Hz * h);
        mean = target + (applied - target) * (1.0 - decay) / (2.0 * kPi * current_loop_Hz * h);
        applied = target + (applied - target) * decay;
      }
      const Eigen::Vector2d i = drive_phase_currents(drive, {mean, delta_rad}, y, kPolePitch_m);
      const double force =
          force_N(y, i) - viscous_N_s_per_m * v - direction_N * std::tanh(v / smoothing_m_per_s);
      v += force / mass_kg * h;
      y += v * h;
    }
  }
  // What the tools give the fit: each setpoint's currents at the middle of
  // its period and of the period after it.
  out.currents_next_A.resize(2, samples);
  const auto middle = [&](Eigen::Index k) {
    return k + 1 < samples ? 0.5 * (out.position_m[k] + out.position_m[k + 1]) : out.position_m[samples - 1];
  };
  for (Eigen::Index k = 0; k < samples; ++k) {
    const double m = magnitude[static_cast<std::size_t>(k)];
    out.currents_A.col(k) = drive_phase_currents(drive, {m, delta_rad}, middle(k), kPolePitch_m);
    out.currents_next_A.col(k) = drive_phase_currents(drive, {m, delta_rad}, middle(k + 1), kPolePitch_m);
  }
  if (magnitude_N != nullptr) *magnitude_N = std::move(magnitude);
  return out;
}

}  // namespace clm::test
