#pragma once
// Commutation finding at power-up (docs/servod.md, "Homing"): on an axis
// whose encoder reads an unknown offset, the phase Δ that gives the most
// driving force through the drive's own commutation, found with bounded
// motion and the loop open. Numerical only: no I/O, no allocation.
//
// The method: N test phases Δ_k = 2πk/N, each applied as a doublet, the
// magnitude +M for n cycles and −M for n cycles at Δ_k to every coil set,
// then zero while the translator comes to rest. A doublet's net impulse is
// zero, so each ends at rest, displaced by r_k ≈ F_k·T²/m where
// F_k = c·M·cos(Δ_k − φ) is what Δ_k drives. The first harmonic of r_k over
// the circle gives φ = atan2(Σ r_k sin Δ_k, Σ r_k cos Δ_k). Friction, the
// same at every phase, takes a dead band off |F_k| and leaves the phase;
// force constant at every phase (cogging, a cable) falls into the mean.
// Phases are taken in opposite pairs (Δ_k, then Δ_k + π), so that each
// pair returns the axis near where it began and the excursion stays within
// one doublet's.

#include <array>
#include <cstdint>

namespace clm::control {

struct CommutationFindingSettings {
  /// The magnitude each coil set is commanded with during a doublet [N], > 0.
  double force_N = 60.0;
  /// The largest displacement from the start the method may cause; a
  /// doublet is sized for an eighth of it on the configured mass, and an
  /// axis that moves farther fails it [m], > 0.
  double max_motion_m = 2e-3;
  /// Zero force after each doublet while the translator comes to rest [s], > 0.
  double settle_s = 0.05;
  /// Test phases over the circle, even, 8..kMaxFindingPhases.
  int phases = 16;
  /// Measurements before an inconsistent one is final, 1..10: a disturbance
  /// during the doublets can bend one, and a repeated one meets another
  /// stretch of it. Every one stays within max_motion_m of the first start.
  int attempts = 3;
  /// Throws std::invalid_argument naming the setting.
  void validate() const;
};

inline constexpr int kMaxFindingPhases = 64;

enum class FindingOutcome : std::uint8_t {
  kRunning,
  kFound,
  kMovedTooFar,  ///< the axis moved beyond max_motion_m from its start
  kNoResponse,   ///< the doublets moved the axis less than a fifth of what the mass predicts
  kInconsistent, ///< the displacements do not follow one sinusoid of the phase
};

/// What the cycle applies this period: `magnitude_N` at `delta_rad` on every coil set.
struct FindingSetpoint {
  double magnitude_N = 0.0;
  double delta_rad = 0.0;
};

class CommutationFinder {
 public:
  /// Starts at `position_m` (the encoder's reading). `total_force_N` is what
  /// the coil sets together drive at the best phase (force_N times their
  /// number, for the drive's nominal motor constant), `mass_kg` the
  /// translator's (control.mass_kg), both only to size the doublets.
  void start(const CommutationFindingSettings& settings, double total_force_N, double mass_kg, double period_s,
             double position_m) noexcept;
  /// One period: the reading of this cycle in, the setpoint to apply out.
  /// `previous_period_lost`: the last period's setpoint may not have reached
  /// the drive in its period (the loop overran or woke a period late), so the
  /// drive held the one before; a doublet whose pulses that hit is
  /// unbalanced and is measured again after its rest.
  FindingSetpoint update(double position_m, bool previous_period_lost = false) noexcept;
  FindingOutcome outcome() const noexcept { return outcome_; }
  bool running() const noexcept { return outcome_ == FindingOutcome::kRunning; }
  /// Once kFound: the phase Δ that drives +y hardest, wrapped to (−π, π] [rad].
  double phase_rad() const noexcept { return phase_rad_; }
  /// The first harmonic's amplitude [m] and the residual's RMS about it [m].
  double amplitude_m() const noexcept { return amplitude_m_; }
  double residual_m() const noexcept { return residual_m_; }
  /// Cycles of one doublet half, and of the whole method.
  int pulse_cycles() const noexcept { return pulse_cycles_; }
  int total_cycles() const noexcept { return phases_ * (2 * pulse_cycles_ + settle_cycles_); }
  /// The test phase of the k-th doublet in time order [rad].
  double test_phase_rad(int k) const noexcept;

 private:
  void finish() noexcept;
  void begin_measurement() noexcept;
  /// An inconsistent measurement: measured again while attempts remain.
  void inconsistent() noexcept;

  CommutationFindingSettings settings_{};
  FindingOutcome outcome_ = FindingOutcome::kFound;
  int phases_ = 0, pulse_cycles_ = 0, settle_cycles_ = 0;
  int doublet_ = 0, cycle_in_doublet_ = 0, attempt_ = 0;
  bool doublet_spoiled_ = false;
  int spoiled_ = 0;  // doublets measured again in this measurement
  double origin_m_ = 0.0, expected_m_ = 0.0;
  double before_m_ = 0.0, rest_sum_m_ = 0.0;
  int rest_count_ = 0;
  std::array<double, kMaxFindingPhases> displacement_m_{};
  double phase_rad_ = 0.0, amplitude_m_ = 0.0, residual_m_ = 0.0;
};

}  // namespace clm::control
