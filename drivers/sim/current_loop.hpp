#pragma once
// The drive's current loop (CurrentLoopParameters): one PI controller per
// independent phase current (i_a, i_b of each coil set; i_c = −i_a − i_b),
// each phase winding R and L with its back-EMF, the bridge's voltage limit.
// A substep is integrated exactly for the linear loop (the matrix
// exponential of the controller and winding, held references and back-EMF);
// where the controller asks for more than the limit, with the limit applied
// and the integrator held (anti-windup). No I/O; step() does not allocate.

#include <Eigen/Core>

#include "commutation/types.hpp"
#include "drivers/sim/parameters.hpp"

namespace clm::sim {

class CurrentLoop {
 public:
  explicit CurrentLoop(const CurrentLoopParameters& parameters) noexcept;

  /// Currents and integrators to 0 (the bridge off), for `channels` currents.
  void reset(int channels) noexcept;
  /// Advances every channel by `h_s` with its reference [A] and back-EMF [V]
  /// held; the currents after it are current_A().
  void step(const CurrentVector& reference_A, const CurrentVector& back_emf_V, double h_s) noexcept;
  const CurrentVector& current_A() const noexcept { return current_A_; }

  double proportional_V_per_A() const noexcept { return kp_; }
  double integral_V_per_A_s() const noexcept { return ki_; }

 private:
  void discretise(double h_s) noexcept;

  CurrentLoopParameters parameters_;
  double kp_ = 0.0;
  double ki_ = 0.0;
  double h_s_ = 0.0;  ///< the substep phi_, gamma_, decay_ are for
  Eigen::Matrix2d phi_ = Eigen::Matrix2d::Identity();  ///< [i, z] ← Φ·[i, z] + Γ·[reference, back-EMF]
  Eigen::Matrix2d gamma_ = Eigen::Matrix2d::Zero();
  double decay_ = 1.0;  ///< exp(−R·h/L): a winding at the voltage limit
  CurrentVector current_A_;
  CurrentVector integral_V_;  ///< the PI's integral part z [V]
};

/// A band-limited force (ForceDisturbanceParameters): kDisturbanceLines
/// sinusoids of equal amplitude, frequencies and phases from the seed, RMS
/// rms_N. Advanced by rotating each line's phasor; no I/O, no allocation.
class ForceDisturbance {
 public:
  explicit ForceDisturbance(const ForceDisturbanceParameters& parameters);
  /// Back to time 0.
  void reset() noexcept;
  /// The force now [N].
  double force_N() const noexcept { return force_N_; }
  /// Advances by `h_s`.
  void step(double h_s) noexcept;
  double frequency_Hz(int line) const noexcept { return frequency_Hz_[static_cast<std::size_t>(line)]; }
  double amplitude_N() const noexcept { return amplitude_N_; }

 private:
  void sum() noexcept;

  ForceDisturbanceParameters parameters_;
  double amplitude_N_ = 0.0;
  std::array<double, kDisturbanceLines> frequency_Hz_{};
  std::array<double, kDisturbanceLines> phase_rad_{};
  std::array<double, kDisturbanceLines> cos_{}, sin_{};        ///< each line's phasor now
  std::array<double, kDisturbanceLines> step_cos_{}, step_sin_{};  ///< its rotation over h_s_
  double h_s_ = 0.0;
  long steps_ = 0;  ///< since the phasors were last set exactly
  double time_s_ = 0.0;
  double force_N_ = 0.0;
};

}  // namespace clm::sim
