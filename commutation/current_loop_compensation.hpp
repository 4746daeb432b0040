#pragma once
// The drive's current loop seen from the commutation (docs/commutation.md,
// "The drive's current loop"): a drive closes a PI loop per phase current
// around a winding R, L with the phase's back-EMF e as its disturbance: v
// times the phase's force constant less the three phases' mean, which the
// star point takes up. Tuned by pole-zero cancellation (K_p = L·ω_c,
// K_i = R·ω_c), a current follows its reference r as
//   i = ω_c/(s + ω_c)·r − s/((L·s + R)(s + ω_c))·e,
// so the references that make the currents i* flow are
//   r = i* + (1/ω_c)·di*/dt + (1/ω_c)·s/(L·s + R)·e.
// The first two terms are i* evaluated 1/ω_c ahead along the motion; the last
// cancels the back-EMF's current, with e from the law's own driving-force
// gain. No I/O; nothing allocates.

#include "commutation/types.hpp"

namespace clm {

/// The drive's current loop as its manual gives it (drive.current_loop of the
/// motor file). bandwidth_Hz 0: currents follow their references at once.
struct CurrentLoopModel {
  double bandwidth_Hz = 0.0;          ///< closed-loop bandwidth ω_c/2π [Hz]
  double phase_resistance_ohm = 0.0;  ///< R of one phase winding [Ω]
  double phase_inductance_H = 0.0;    ///< L of one phase winding [H]
  bool ideal() const noexcept { return bandwidth_Hz == 0.0; }
  /// The loop's lag 1/ω_c, the time constant of its first-order response [s]; 0 when ideal.
  double lag_s() const noexcept { return ideal() ? 0.0 : 1.0 / (kTwoPi * bandwidth_Hz); }
  /// Throws std::invalid_argument naming the value that is out of range.
  void validate() const;

  /// What validate() and the motor file's reader accept (ideal aside).
  static constexpr double kMinBandwidth_Hz = 1.0, kMaxBandwidth_Hz = 1e5;
  static constexpr double kMinResistance_ohm = 1e-4, kMaxResistance_ohm = 1e4;
  static constexpr double kMinInductance_H = 1e-7, kMaxInductance_H = 10.0;
};

/// The references a cycle sends so that the drive's current loop delivers the
/// currents the law asked for. State: the back-EMF of the last two cycles
/// (its derivative by differences).
class CurrentLoopCompensation {
 public:
  CurrentLoopCompensation(const CurrentLoopModel& model, double period_s);

  bool active() const noexcept { return !model_.ideal(); }
  /// How far ahead along the motion the law is evaluated, 1/ω_c [s]; 0 when ideal.
  double lead_s() const noexcept { return lead_s_; }
  /// Forgets the back-EMF history: after a cycle without commutation.
  void reset() noexcept { history_ = 0; }
  /// `currents_A`: the law's currents 1/ω_c ahead; `driving_gain_N_per_A`:
  /// its ∂F_y/∂i there, one per current; `velocity_m_per_s`: the axis's.
  /// Writes currents_A plus the back-EMF's correction to `references_A`.
  void references(const CurrentVector& currents_A, const CurrentVector& driving_gain_N_per_A,
                  double velocity_m_per_s, CurrentVector& references_A) noexcept;

 private:
  CurrentLoopModel model_;
  double period_s_;
  double lead_s_ = 0.0;
  /// 1/(R·ω_c) [A/(V/s)]: the back-EMF's derivative to the reference's correction.
  double gain_s_per_ohm_ = 0.0;
  /// Where between the last two derivatives the one the correction needs
  /// lies, in periods (docs/commutation.md, "The drive's current loop").
  double extrapolation_ = 0.0;
  int history_ = 0;
  CurrentVector emf_V_;
  CurrentVector derivative_V_per_s_;
};

}  // namespace clm
