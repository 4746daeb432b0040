#include "daemon/control/commutation_finding.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "commutation/elementary.hpp"
#include "commutation/transform.hpp"

namespace clm::control {
namespace {

constexpr double kPi = 3.14159265358979323846;
// The rest position after a doublet is the mean of this many readings at
// the end of its settling time (encoder noise, the mode's last ringing).
constexpr int kRestWindow = 10;
// Less than this share of the displacement the mass predicts: the drive
// drives nothing (not connected, no power stage, blocked axis).
constexpr double kLeastResponse = 0.2;
// The odd part's deviation from one sinusoid may reach this share of its
// amplitude: friction and a force the same at every phase cut a dead band
// out of it (0.30 measured where they add up to the doublet's force at a
// quarter of the phases), and displacements no phase explains (noise, an
// axis pushed by hand) give about 1.2.
constexpr double kMostResidual = 0.5;
// The share of max_motion_m one doublet moves the axis.
constexpr double kDoubletShare = 0.125;

}  // namespace

void CommutationFindingSettings::validate() const {
  const auto fail = [](const std::string& what, double value, const std::string& rule) {
    throw std::invalid_argument("homing.commutation_finding." + what + ": " + std::to_string(value) + " " + rule);
  };
  if (!(force_N > 0.0 && std::isfinite(force_N))) fail("force_N", force_N, "must be positive and finite");
  if (!(max_motion_m > 0.0 && max_motion_m <= 0.05)) fail("max_motion_m", max_motion_m, "must lie in (0, 0.05] m");
  if (!(settle_s > 0.0 && settle_s <= 2.0)) fail("settle_s", settle_s, "must lie in (0, 2] s");
  if (phases < 8 || phases > kMaxFindingPhases || phases % 2 != 0) {
    fail("phases", phases, "must be even and lie in 8.." + std::to_string(kMaxFindingPhases));
  }
  if (attempts < 1 || attempts > 10) fail("attempts", attempts, "must lie in 1..10");
}

void CommutationFinder::start(const CommutationFindingSettings& settings, double total_force_N, double mass_kg,
                              double period_s, double position_m) noexcept {
  settings_ = settings;
  phases_ = settings.phases;
  // A doublet of ±F for T each moves m·x = F·T²: T for kDoubletShare of
  // the bound. The rest is margin for what a force the same at every phase
  // (cogging, a cable, the direction-dependent force) adds while the
  // translator moves: about that force over F of a doublet's motion per
  // doublet, always the same way.
  const double pulse_s = std::sqrt(kDoubletShare * settings.max_motion_m * mass_kg / total_force_N);
  pulse_cycles_ = std::max(2, static_cast<int>(std::floor(pulse_s / period_s)));
  settle_cycles_ = std::max(2 * kRestWindow, static_cast<int>(std::lround(settings.settle_s / period_s)));
  const double pulse_T_s = pulse_cycles_ * period_s;
  expected_m_ = total_force_N * pulse_T_s * pulse_T_s / mass_kg;
  origin_m_ = before_m_ = position_m;
  attempt_ = 0;
  begin_measurement();
}

void CommutationFinder::begin_measurement() noexcept {
  // From where the last measurement left the axis (before_m_), the bound
  // still about the first start (origin_m_).
  ++attempt_;
  doublet_ = cycle_in_doublet_ = rest_count_ = spoiled_ = 0;
  doublet_spoiled_ = false;
  rest_sum_m_ = 0.0;
  displacement_m_.fill(0.0);
  phase_rad_ = amplitude_m_ = residual_m_ = 0.0;
  outcome_ = FindingOutcome::kRunning;
}

double CommutationFinder::test_phase_rad(int k) const noexcept {
  // Opposite pairs: 0, π, 2π/N, π + 2π/N, ...
  const int index = k / 2 + (k % 2) * (phases_ / 2);
  return wrap_angle_rad(2.0 * kPi * index / phases_);
}

FindingSetpoint CommutationFinder::update(double position_m, bool previous_period_lost) noexcept {
  if (outcome_ != FindingOutcome::kRunning) return {};
  if (!(std::abs(position_m - origin_m_) <= settings_.max_motion_m)) {
    outcome_ = FindingOutcome::kMovedTooFar;
    return {};
  }
  const int c = cycle_in_doublet_;
  const int doublet_cycles = 2 * pulse_cycles_ + settle_cycles_;
  // The last period was one of the pulses (or the −M one held into the rest).
  if (previous_period_lost && c >= 1 && c <= 2 * pulse_cycles_ + 1) doublet_spoiled_ = true;
  FindingSetpoint setpoint;
  if (c < 2 * pulse_cycles_) {
    setpoint.magnitude_N = c < pulse_cycles_ ? settings_.force_N : -settings_.force_N;
    setpoint.delta_rad = test_phase_rad(doublet_);
  } else if (c >= doublet_cycles - kRestWindow) {
    rest_sum_m_ += position_m;
    ++rest_count_;
  }
  if (++cycle_in_doublet_ == doublet_cycles) {
    const double rest_m = rest_sum_m_ / rest_count_;
    if (!doublet_spoiled_) displacement_m_[static_cast<std::size_t>(doublet_)] = rest_m - before_m_;
    before_m_ = rest_m;
    rest_sum_m_ = 0.0;
    rest_count_ = cycle_in_doublet_ = 0;
    if (doublet_spoiled_) {
      // The same test phase again; a loop that loses a period in every
      // other doublet does not give a measurement.
      doublet_spoiled_ = false;
      if (++spoiled_ > phases_) inconsistent();
    } else if (++doublet_ == phases_) {
      finish();
    }
  }
  return setpoint;
}

void CommutationFinder::inconsistent() noexcept {
  outcome_ = FindingOutcome::kInconsistent;
  if (attempt_ < settings_.attempts) begin_measurement();
}

void CommutationFinder::finish() noexcept {
  // The first harmonic over the circle (uniform phases: the discrete
  // Fourier coefficients are the least-squares fit; a force the same at
  // every phase falls into the mean, which the phase does not need).
  double a = 0.0, b = 0.0;
  for (int k = 0; k < phases_; ++k) {
    const double r = displacement_m_[static_cast<std::size_t>(k)];
    const double angle = test_phase_rad(k);
    a += r * elementary::cos(angle);
    b += r * elementary::sin(angle);
  }
  a *= 2.0 / phases_;
  b *= 2.0 / phases_;
  // The consistency is judged on the odd part, half the difference of each
  // opposite pair (doublets 2j and 2j + 1): a force the same at every phase
  // meets friction differently when it adds to the doublet's and when it
  // opposes it, which bends the even part but leaves the odd part an odd
  // function of the force at Δ, whose first harmonic is at φ.
  double square_sum = 0.0;
  for (int j = 0; j < phases_ / 2; ++j) {
    const double angle = test_phase_rad(2 * j);
    const double odd = 0.5 * (displacement_m_[static_cast<std::size_t>(2 * j)] -
                              displacement_m_[static_cast<std::size_t>(2 * j + 1)]);
    const double deviation = odd - (a * elementary::cos(angle) + b * elementary::sin(angle));
    square_sum += deviation * deviation;
  }
  amplitude_m_ = std::hypot(a, b);
  residual_m_ = std::sqrt(square_sum / (phases_ / 2));
  phase_rad_ = wrap_angle_rad(elementary::atan2(b, a));
  if (amplitude_m_ < kLeastResponse * expected_m_) {
    outcome_ = FindingOutcome::kNoResponse;
  } else if (residual_m_ > kMostResidual * amplitude_m_) {
    inconsistent();
  } else {
    outcome_ = FindingOutcome::kFound;
  }
}

}  // namespace clm::control
