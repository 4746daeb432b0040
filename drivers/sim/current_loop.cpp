#include "drivers/sim/current_loop.hpp"

#include <cmath>

#include "commutation/elementary.hpp"
#include "commutation/types.hpp"
#include "drivers/sim/random.hpp"

namespace clm::sim {

namespace {


/// exp(M) of a 4 × 4 matrix: scaling until the norm is at most 1/8, a
/// Taylor series of 14 terms, squaring back. Plain arithmetic, the same bits
/// on every CPU.
Eigen::Matrix4d exponential(const Eigen::Matrix4d& m) {
  int squarings = 0;
  double norm = m.cwiseAbs().rowwise().sum().maxCoeff();
  Eigen::Matrix4d scaled = m;
  while (norm > 0.125) {
    scaled *= 0.5;
    norm *= 0.5;
    ++squarings;
  }
  Eigen::Matrix4d result = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d term = Eigen::Matrix4d::Identity();
  for (int k = 1; k <= 14; ++k) {
    term = term * scaled / static_cast<double>(k);
    result += term;
  }
  for (int k = 0; k < squarings; ++k) result = result * result;
  return result;
}

}  // namespace

CurrentLoop::CurrentLoop(const CurrentLoopParameters& parameters) noexcept : parameters_(parameters) {
  const double omega = kTwoPi * parameters.bandwidth_Hz;
  kp_ = parameters.phase_inductance_H * omega;
  ki_ = parameters.phase_resistance_ohm * omega;
  reset(0);
}

void CurrentLoop::reset(int channels) noexcept {
  current_A_.setZero(channels);
  integral_V_.setZero(channels);
}

void CurrentLoop::discretise(double h_s) noexcept {
  // x = [i, z]: L·di/dt = K_p·(r − i) + z − R·i − e, dz/dt = K_i·(r − i).
  // exp([[A, B], [0, 0]]·h) = [[Φ, Γ], [0, I]].
  const double r = parameters_.phase_resistance_ohm, l = parameters_.phase_inductance_H;
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m(0, 0) = -(kp_ + r) / l;
  m(0, 1) = 1.0 / l;
  m(1, 0) = -ki_;
  m(0, 2) = kp_ / l;
  m(0, 3) = -1.0 / l;
  m(1, 2) = ki_;
  const Eigen::Matrix4d e = exponential(m * h_s);
  phi_ = e.topLeftCorner<2, 2>();
  gamma_ = e.topRightCorner<2, 2>();
  decay_ = elementary::exp(-r * h_s / l);
  h_s_ = h_s;
}

void CurrentLoop::step(const CurrentVector& reference_A, const CurrentVector& back_emf_V, double h_s) noexcept {
  if (h_s != h_s_) discretise(h_s);
  const double limit = parameters_.voltage_limit_V, r = parameters_.phase_resistance_ohm;
  for (Eigen::Index c = 0; c < current_A_.size(); ++c) {
    const double i = current_A_[c], z = integral_V_[c], ref = reference_A[c], emf = back_emf_V[c];
    const double asked_V = kp_ * (ref - i) + z;
    if (std::abs(asked_V) <= limit) {
      current_A_[c] = phi_(0, 0) * i + phi_(0, 1) * z + gamma_(0, 0) * ref + gamma_(0, 1) * emf;
      integral_V_[c] = phi_(1, 0) * i + phi_(1, 1) * z + gamma_(1, 0) * ref + gamma_(1, 1) * emf;
    } else {
      // The bridge at its limit: the winding alone, the integrator held.
      const double settled_A = ((asked_V > 0.0 ? limit : -limit) - emf) / r;
      current_A_[c] = settled_A + (i - settled_A) * decay_;
    }
  }
}

ForceDisturbance::ForceDisturbance(const ForceDisturbanceParameters& parameters) : parameters_(parameters) {
  RandomStream random(stream_seed(parameters.seed, 1));
  for (int k = 0; k < kDisturbanceLines; ++k) {
    const auto line = static_cast<std::size_t>(k);
    frequency_Hz_[line] = parameters.low_Hz + (parameters.high_Hz - parameters.low_Hz) * random.uniform();
    phase_rad_[line] = kTwoPi * random.uniform();
  }
  // Lines of equal amplitude a: RMS a·sqrt(N/2).
  amplitude_N_ = parameters.rms_N * std::sqrt(2.0 / kDisturbanceLines);
  reset();
}

void ForceDisturbance::reset() noexcept {
  time_s_ = 0.0;
  steps_ = 0;
  for (std::size_t k = 0; k < cos_.size(); ++k) {
    cos_[k] = elementary::cos(phase_rad_[k]);
    sin_[k] = elementary::sin(phase_rad_[k]);
  }
  sum();
}

void ForceDisturbance::step(double h_s) noexcept {
  if (parameters_.rms_N == 0.0) return;
  time_s_ += h_s;
  if (h_s != h_s_ || ++steps_ >= 4096) {
    // A new substep, or rounding to correct: the phasors exactly at time_s_.
    h_s_ = h_s;
    steps_ = 0;
    for (std::size_t k = 0; k < cos_.size(); ++k) {
      const double angle = kTwoPi * frequency_Hz_[k] * h_s;
      step_cos_[k] = elementary::cos(angle);
      step_sin_[k] = elementary::sin(angle);
      const double now = phase_rad_[k] + kTwoPi * frequency_Hz_[k] * time_s_;
      cos_[k] = elementary::cos(now);
      sin_[k] = elementary::sin(now);
    }
  } else {
    for (std::size_t k = 0; k < cos_.size(); ++k) {
      const double c = cos_[k] * step_cos_[k] - sin_[k] * step_sin_[k];
      sin_[k] = sin_[k] * step_cos_[k] + cos_[k] * step_sin_[k];
      cos_[k] = c;
    }
  }
  sum();
}

void ForceDisturbance::sum() noexcept {
  double total = 0.0;
  for (double s : sin_) total += s;
  force_N_ = parameters_.rms_N == 0.0 ? 0.0 : amplitude_N_ * total;
}

}  // namespace clm::sim
