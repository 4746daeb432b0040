#include "commutation/current_loop_compensation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace clm {

void CurrentLoopModel::validate() const {
  if (ideal()) return;
  const auto require = [](double value, double low, double high, const char* name) {
    if (!(value >= low && value <= high)) {
      throw std::invalid_argument(std::string("current loop: ") + name + " must lie in [" + std::to_string(low) +
                                  ", " + std::to_string(high) + "], got " + std::to_string(value));
    }
  };
  require(bandwidth_Hz, kMinBandwidth_Hz, kMaxBandwidth_Hz, "bandwidth_Hz");
  require(phase_resistance_ohm, kMinResistance_ohm, kMaxResistance_ohm, "phase_resistance_ohm");
  require(phase_inductance_H, kMinInductance_H, kMaxInductance_H, "phase_inductance_H");
}

CurrentLoopCompensation::CurrentLoopCompensation(const CurrentLoopModel& model, double period_s)
    : model_(model), period_s_(period_s) {
  model.validate();
  if (!(period_s > 0.0)) throw std::invalid_argument("current loop compensation: the period must be positive");
  emf_V_.setZero(kMaxCurrents);
  derivative_V_per_s_.setZero(kMaxCurrents);
  if (!active()) return;
  const double omega_rad_per_s = kTwoPi * model.bandwidth_Hz;
  lead_s_ = model.lag_s();
  gain_s_per_ohm_ = 1.0 / (model.phase_resistance_ohm * omega_rad_per_s);
  // The difference of the back-EMF 1/ω_c ahead over the last period is its
  // derivative at lead − T/2 from now; the correction needs it at −L/R (the
  // winding's lag, s/(Ls + R) ≈ (s/R)·e^(−s·L/R) well below R/L). Linear
  // extrapolation over at most one period either way.
  const double winding_s = model.phase_inductance_H / model.phase_resistance_ohm;
  extrapolation_ = std::clamp((0.5 * period_s - lead_s_ - winding_s) / period_s, -1.0, 1.0);
}

void CurrentLoopCompensation::references(const CurrentVector& currents_A, const CurrentVector& driving_gain_N_per_A,
                                         double velocity_m_per_s, CurrentVector& references_A) noexcept {
  references_A = currents_A;
  if (!active()) return;
  const Eigen::Index n = currents_A.size();
  for (Eigen::Index k = 0; k < n; ++k) {
    // Back-EMF of phase a (b): v times its force constant less the three
    // phases' mean, (2·∂F_y/∂i_a − ∂F_y/∂i_b)/3 (and a, b swapped) with
    // i_c = −i_a − i_b; the star point takes up the mean.
    const Eigen::Index other = k ^ 1;
    const double emf_V =
        velocity_m_per_s * (2.0 * driving_gain_N_per_A[k] - driving_gain_N_per_A[other]) / 3.0;
    const double derivative_V_per_s = (emf_V - emf_V_[k]) / period_s_;
    double used_V_per_s = 0.0;
    if (history_ >= 2) {
      used_V_per_s = derivative_V_per_s + extrapolation_ * (derivative_V_per_s - derivative_V_per_s_[k]);
    } else if (history_ == 1) {
      used_V_per_s = derivative_V_per_s;
    }
    references_A[k] += gain_s_per_ohm_ * used_V_per_s;
    emf_V_[k] = emf_V;
    derivative_V_per_s_[k] = history_ >= 1 ? derivative_V_per_s : 0.0;
  }
  history_ = std::min(history_ + 1, 2);
}

}  // namespace clm
