#include "daemon/control/loop_analysis.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

#include "commutation/elementary.hpp"
#include "commutation/types.hpp"
#include <stdexcept>
#include <string>

namespace clm::control {

namespace {

using Complex = std::complex<double>;
constexpr double kLn10 = 2.302585092994046;

/// e^(−j·x), by the project's CPU-independent functions.
Complex unit_delay(double x) { return {elementary::cos(x), -elementary::sin(x)}; }

}  // namespace

std::complex<double> plant_response(const PlantModel& plant, double frequency_Hz) {
  const double w = kTwoPi * frequency_Hz;
  const Complex s(0.0, w);
  Complex p = 1.0 / (plant.mass_kg * s * s);
  if (plant.mode_frequency_Hz > 0.0) {
    const double wm = kTwoPi * plant.mode_frequency_Hz, z = plant.mode_damping_ratio;
    p *= (2.0 * z * wm * s + wm * wm) / (s * s + 2.0 * z * wm * s + wm * wm);
  }
  if (plant.current_loop_bandwidth_Hz > 0.0) {
    const double wc = kTwoPi * plant.current_loop_bandwidth_Hz;
    p *= wc / (s + wc);
  }
  if (plant.delay_s > 0.0) p *= unit_delay(w * plant.delay_s);
  return p;
}

std::complex<double> controller_response(const PidGains& gains, double period_s, double frequency_Hz) {
  // z = e^(jωT): (2/T)·(z − 1)/(z + 1) = j·(2/T)·tan(ωT/2).
  const double half_wt = kPi * frequency_Hz * period_s;
  const Complex s(0.0, 2.0 / period_s * elementary::sin(half_wt) / elementary::cos(half_wt));
  const double w_lp = kTwoPi * gains.lowpass_hz;
  return (gains.proportional_N_per_m + gains.integral_N_per_m_s / s + gains.derivative_N_s_per_m * s) /
         (s / w_lp + 1.0);
}

std::complex<double> loop_response(const PidGains& gains, double period_s, const PlantModel& plant,
                                   double frequency_Hz) {
  const double wt = kTwoPi * frequency_Hz * period_s;
  const Complex hold = (1.0 - unit_delay(wt)) / Complex(0.0, wt);
  return controller_response(gains, period_s, frequency_Hz) * hold * plant_response(plant, frequency_Hz);
}

LoopMargins loop_margins(const PidGains& gains, double period_s, const PlantModel& plant) {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) {
    throw std::invalid_argument("loop period " + std::to_string(period_s) + " s: must be positive and finite");
  }
  if (!(plant.mass_kg > 0.0) || !std::isfinite(plant.mass_kg)) {
    throw std::invalid_argument("plant mass " + std::to_string(plant.mass_kg) + " kg: must be positive and finite");
  }
  const double low_Hz = 0.1, high_Hz = 0.5 / period_s * (1.0 - 1e-6);
  const double decades = elementary::log(high_Hz / low_Hz) / kLn10;
  const int points = static_cast<int>(std::ceil(4000.0 * decades));
  LoopMargins margins;
  margins.phase_margin_deg = std::numeric_limits<double>::infinity();
  margins.gain_margin_dB = std::numeric_limits<double>::infinity();
  double previous_f = 0.0, previous_gain = 0.0, previous_phase = 0.0;
  for (int k = 0; k <= points; ++k) {
    const double f = low_Hz * elementary::exp(decades * kLn10 * k / points);
    const Complex l = loop_response(gains, period_s, plant, f);
    const double gain = std::abs(l);
    // The phase unwrapped along the grid (steps of less than π between points).
    double phase = elementary::atan2(l.imag(), l.real());
    if (k > 0) phase += kTwoPi * std::round((previous_phase - phase) / kTwoPi);
    margins.peak_sensitivity = std::max(margins.peak_sensitivity, 1.0 / std::abs(1.0 + l));
    if (k > 0) {
      if ((previous_gain - 1.0) * (gain - 1.0) <= 0.0 && previous_gain != gain) {
        // A gain crossover between the two points: interpolate in log gain.
        const double t = elementary::log(previous_gain) / (elementary::log(previous_gain) - elementary::log(gain));
        const double crossing_phase = previous_phase + t * (phase - previous_phase);
        // The rotation that would take L onto −1: the distance of its phase
        // to the nearest odd multiple of 180°, 0..180°.
        const double turns = (crossing_phase + kPi) / kTwoPi;
        const double pm = std::abs(turns - std::round(turns)) * 360.0;
        ++margins.gain_crossovers;
        if (pm < margins.phase_margin_deg) {
          margins.phase_margin_deg = pm;
          margins.crossover_Hz = previous_f + t * (f - previous_f);
        }
      }
      // A phase crossover: the phase passes an odd multiple of −180°.
      const double a = (previous_phase + kPi) / kTwoPi, b = (phase + kPi) / kTwoPi;
      if (std::floor(a) != std::floor(b)) {
        const double target = (std::max(std::floor(a), std::floor(b))) * kTwoPi - kPi;
        const double t = (target - previous_phase) / (phase - previous_phase);
        const double log_gain = elementary::log(previous_gain) + t * (elementary::log(gain) - elementary::log(previous_gain));
        // Left of −1: a crossing of the negative real axis (stable()).
        if (log_gain > 0.0) margins.real_axis_crossings += phase > previous_phase ? 1 : -1;
        // Only above the first gain crossover: below it the integrator and
        // the mass together pass −180° with |L| ≫ 1, which bounds how far the
        // gain may fall, not rise.
        const double gm_dB = -20.0 * log_gain / kLn10;
        if (margins.gain_crossovers > 0 && gm_dB < margins.gain_margin_dB) {
          margins.gain_margin_dB = gm_dB;
          margins.gain_margin_Hz = previous_f + t * (f - previous_f);
        }
      }
    }
    previous_f = f;
    previous_gain = gain;
    previous_phase = phase;
  }
  return margins;
}

PlantModel described_plant(const MotorDescription& motor, double mass_kg) {
  return {.mass_kg = mass_kg,
          .mode_frequency_Hz = motor.flexible_mode_Hz,
          .mode_damping_ratio = motor.flexible_mode_damping_ratio,
          .current_loop_bandwidth_Hz = motor.current_loop.bandwidth_Hz,
          .delay_s = motor.setpoint_delay_s + motor.position_delay_s};
}

std::string margin_shortfall(const PidGains& gains, double period_s, const PlantModel& plant) {
  const LoopMargins m = loop_margins(gains, period_s, plant);
  if (!m.stable()) {
    char text[160];
    std::snprintf(text, sizeof text,
                  "unstable (where |L| > 1 its phase passes -180 deg, mod 360, a net %d times counted +1 rising; a "
                  "stable loop once)",
                  m.real_axis_crossings);
    return text;
  }
  const bool gain_short = m.gain_margin_Hz > 0.0 && m.gain_margin_dB < kMinGainMargin_dB;
  if (m.phase_margin_deg >= kMinPhaseMargin_deg && !gain_short) return "";
  char text[160];
  std::snprintf(text, sizeof text, "short of the least margins (phase margin %.1f deg at %.0f Hz, at least %.0f; gain margin ", m.phase_margin_deg,
                m.crossover_Hz, kMinPhaseMargin_deg);
  std::string out = text;
  if (m.gain_margin_Hz > 0.0) {
    std::snprintf(text, sizeof text, "%.1f dB at %.0f Hz, at least %.0f)", m.gain_margin_dB, m.gain_margin_Hz,
                  kMinGainMargin_dB);
  } else {
    std::snprintf(text, sizeof text, "unbounded, at least %.0f dB)", kMinGainMargin_dB);
  }
  return out + text;
}

}  // namespace clm::control
