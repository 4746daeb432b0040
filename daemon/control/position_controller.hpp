#pragma once
// The position loop of the translator: a PID feedback controller with a
// first-order low-pass, the feedforward of eq. (40) with a one-sample preview
// of the reference, its least-squares identification from closed-loop data
// (docs/commutation.md §10), and the two combined.
//
// The update()/feedforward functions run in the cycle: noexcept, no
// allocation. Construction, tuning and identification are offline and throw
// std::invalid_argument with the offending value.

#include <span>
#include <string>
#include <vector>

#include "daemon/control/trajectory.hpp"

namespace clm::control {

/// Gains of the feedback controller
///   C(s) = (k_p + k_i/s + k_d·s) · 1/(s/(2π·f_lp) + 1),
/// i.e. a parallel PID whose whole output (so also the derivative) passes a
/// first-order low-pass; the low-pass makes C proper and limits the noise gain
/// at high frequency to k_d·2π·f_lp.
struct PidGains {
  double proportional_N_per_m;  ///< k_p [N/m]
  double integral_N_per_m_s;    ///< k_i [N/(m·s)]
  double derivative_N_s_per_m;  ///< k_d [N·s/m]
  double lowpass_hz;            ///< f_lp, corner of the output low-pass [Hz], > 0
};

/// Loop shaping for a rigid mass P(s) = 1/(m s²) at the crossover ω_c = 2π·bandwidth_hz.
///
/// Fixed ratios: derivative zero at ω_d = k_p/k_d = ω_c/√3 (the lead of a
/// PD whose phase is centred on ω_c), integrator corner ω_i = k_i/k_p = ω_c/5,
/// low-pass ω_lp = 5·ω_c. At ω_c,
///   C(jω_c) = k_p·(1 + j(√3 − 1/5)) / (1 + j/5),
/// so |L(jω_c)| = |C(jω_c)|/(m ω_c²) = 1 gives
///   k_p = m ω_c² · √(1 + 1/25) / √(1 + (√3 − 1/5)²) ≈ 0.557·m ω_c²,
///   k_d = √3·k_p/ω_c,  k_i = k_p·ω_c/5,
/// and the phase margin is atan(√3 − 1/5) − atan(1/5) ≈ 56.9° − 11.3° = 45.6°
/// in continuous time. The sampled loop loses about ω_c·T_s/2 (zero-order
/// hold) plus any computation delay on top; keep ω_c·T_s small.
/// (The textbook k_p = m ω_c²/3, k_d = m ω_c/√3 gives |L(jω_c)| = 2/3 only, so
/// the crossover lands below ω_c.)
/// Throws std::invalid_argument if mass or bandwidth is not positive and
/// finite, or if the gains overflow (are not finite).
PidGains tune_pid(double mass_kg, double bandwidth_hz);

/// The PID of PidGains, discretised with the Tustin (bilinear) transform,
/// s → (2/T_s)(z−1)/(z+1), per term:
///   integrator   I_k = I_{k−1} + k_i·T_s/2·(e_k + e_{k−1})      (trapezoidal),
///   P + I path   low-pass of (k_p e + I),
///   D path       k_d·s/(s/ω_lp + 1) as one Tustin section,
/// so the output equals the Tustin image of C(s) (no prewarping; the
/// frequency warp at ω_c is (ω_c T_s)²/12 relative, negligible for
/// ω_c T_s ≪ 1). Any f_lp > 0 is stable; above about a fifth of the sampling
/// rate the low-pass corner is compressed towards Nyquist by the warp.
///
/// The first update() after construction or reset() takes the previous error
/// equal to the current one (bumpless start: no derivative kick from a
/// non-zero initial error). All state starts at zero.
class PidController {
 public:
  /// Throws std::invalid_argument if a gain is negative or not finite, if
  /// lowpass_hz is not positive and finite, or if period_s is not positive
  /// and finite.
  PidController(const PidGains& gains, double period_s);

  /// One sample: error e_k = r_k − y_k [m] in, force [N] out.
  double update(double error_m) noexcept;
  /// Clears all state (integrator, filters, previous error).
  void reset() noexcept;

  /// New gains from the next update on. The integrator's force I_k and the
  /// filters' states (all in N) are kept, so the output does not jump at rest.
  /// The caller guarantees gains the constructor would accept.
  void set_gains(const PidGains& gains) noexcept;

  /// Anti-windup: clamps the integrator contribution I_k to ±limit [N]
  /// (before the low-pass). Default: no limit (infinity). Throws
  /// std::invalid_argument unless limit_N > 0 (infinity allowed).
  void set_integrator_limit_N(double limit_N);
  double integrator_limit_N() const { return integrator_limit_N_; }
  /// True when the last update() clamped the integrator.
  bool integrator_limited() const noexcept { return integrator_limited_; }
  /// Integrator contribution I_k [N] after the last update.
  double integrator_N() const noexcept { return integrator_N_; }
  /// Output of the last update [N].
  double output_N() const noexcept { return output_N_; }

  const PidGains& gains() const { return gains_; }
  double period_s() const { return period_s_; }

 private:
  PidGains gains_;
  double period_s_;
  double pole_;              ///< Tustin low-pass pole (α−1)/(α+1), α = 2/(ω_lp T_s)
  double input_scale_;       ///< 1/(α+1)
  double derivative_scale_;  ///< 2·k_d/T_s/(α+1)
  double integrator_limit_N_;
  bool started_ = false;
  bool integrator_limited_ = false;
  double previous_error_m_ = 0.0;
  double integrator_N_ = 0.0;
  double previous_proportional_integral_N_ = 0.0;
  double proportional_integral_filtered_N_ = 0.0;
  double derivative_filtered_N_ = 0.0;
  double output_N_ = 0.0;
};

/// Parameters of the feedforward of eq. (40).
struct FeedforwardParameters {
  double mass_kg = 0;            ///< m [kg]
  double viscous_N_s_per_m = 0;  ///< f_v [N·s/m]
  double coulomb_N = 0;          ///< f_c [N]
};

/// Eq. (40) with δ = (z+1)/2: each reference derivative is averaged over the
/// current sample and the one-sample preview `next`,
///   u = m·(a_k + a_{k+1})/2 + f_v·(v_k + v_{k+1})/2 + f_c·(sgn v_k + sgn v_{k+1})/2,
/// with sgn(0) = 0. The average matches the zero-order hold: the force held
/// over [t_k, t_{k+1}] changes the velocity by T_s·(a_k + a_{k+1})/2, exactly
/// for a reference of piecewise-constant jerk. Returns [N].
double feedforward_force_N(const FeedforwardParameters& parameters, const ReferenceSample& now,
                           const ReferenceSample& next) noexcept;

/// Least-squares fit of m, f_v, f_c (docs/commutation.md §10): the N−1 equations
///   F*_k = m·(a_k + a_{k+1})/2 + f_v·(v_k + v_{k+1})/2 + f_c·(sgn v_k + sgn v_{k+1})/2,
/// k = 0..N−2, from the reference and the force demand F*_k [N] recorded in
/// closed loop (the last force sample is unused). Solved by a column-pivoted
/// QR of the column-normalised regressor matrix.
/// Throws std::invalid_argument if the sizes differ, N < 3, a value is not
/// finite (index named), or the regressors are rank-deficient: the reference
/// never accelerates, never moves, or its velocity and direction regressors
/// are collinear (e.g. constant velocity in one direction only).
FeedforwardParameters identify_feedforward(std::span<const ReferenceSample> reference,
                                           std::span<const double> force_demand_N);

/// The fit of identify_feedforward with its quality: what a user needs to
/// judge whether the data excited each parameter.
struct FeedforwardFit {
  FeedforwardParameters parameters;
  double residual_rms_N = 0.0;  ///< RMS of F* − the fitted feedforward [N]
  /// σ_max/σ_min of the column-normalised regressors [a, v, sgn v]: 1 for
  /// orthogonal regressors, large when two of them move together.
  double condition = 0.0;
  /// One standard error of m [kg], f_v [N·s/m] and f_c [N], from the residual
  /// and (XᵀX)⁻¹ (independent residuals assumed, so a lower bound).
  FeedforwardParameters standard_error;
  std::size_t samples = 0;
};

/// identify_feedforward, with the fit's quality. Throws as it does.
FeedforwardFit fit_feedforward(std::span<const ReferenceSample> reference, std::span<const double> force_demand_N);

/// The parameters whose standard error exceeds `relative` of their value
/// (0.1: ten per cent), as "mass_kg", "viscous_N_s_per_m", "coulomb_N": the
/// ones the data did not excite.
std::vector<std::string> unexcited_parameters(const FeedforwardFit& fit, double relative = 0.1);

/// Velocity, acceleration and jerk of a sampled position reference (e.g. a CSV
/// with only t_s, r_m) by finite differences of the quadratic through three
/// neighbouring samples (time steps may be non-uniform):
///   velocity     — central three-point derivative inside, one-sided
///                  three-point at both ends;
///   acceleration — second derivative of the same quadratic (centred inside,
///                  one-sided at the ends);
///   jerk         — the three-point first derivative applied to the acceleration.
/// Accuracy for a uniform step h: inside, velocity error h²/6·|r⃛| and
/// acceleration error h²/12·|r⁗| (exact for cubics); at the two ends the
/// velocity error is h²/3·|r⃛| and the acceleration error h·|r⃛|. For a
/// jerk-limited reference (r⃛ piecewise constant, |r⃛| ≤ j_max) this gives
/// |velocity error| ≤ j_max·h²/3 everywhere and an acceleration error ≤ j_max·h
/// near jerk switches and ends, zero elsewhere. The jerk is first order and
/// smears each jerk switch over about two samples. Position samples are copied
/// unchanged. Throws std::invalid_argument if the sizes differ, N < 3, a value
/// is not finite or time does not strictly increase (index named).
std::vector<ReferenceSample> reference_from_positions(std::span<const double> time_s,
                                                      std::span<const double> reference_m);

/// Feedback plus feedforward: F*_y = PID(r_k − y_k) + u_ff(r(t_k + τ), r(t_{k+1} + τ)) [N],
/// τ the drive's lag from setpoint to force (0 for none).
class PositionController {
 public:
  /// Throws as PidController; also if a feedforward parameter is not finite.
  PositionController(const PidGains& gains, const FeedforwardParameters& feedforward, double period_s);

  /// One cycle: the feedback on the reference `now` and the measured
  /// position y_k [m]; the feedforward (eq. 40) on `ahead` and its
  /// one-sample preview `ahead_next`: the reference sampled the drive's lag
  /// after now, so that its force arrives on time (now and the next sample
  /// for a drive without lag). Returns the force demand F*_y [N].
  double update(const ReferenceSample& now, double measured_position_m, const ReferenceSample& ahead,
                const ReferenceSample& ahead_next) noexcept;
  /// Replaces the feedforward parameters (from the next update on). The
  /// caller guarantees finite values (check offline, e.g. with the
  /// constructor or identify_feedforward).
  void set_feedforward(const FeedforwardParameters& feedforward) noexcept { feedforward_ = feedforward; }
  const FeedforwardParameters& feedforward() const noexcept { return feedforward_; }
  /// Clears the PID state and the last outputs.
  void reset() noexcept;

  /// New PID gains, see PidController::set_gains.
  void set_gains(const PidGains& gains) noexcept { pid_.set_gains(gains); }
  /// Anti-windup of the PID integrator, see PidController::set_integrator_limit_N.
  void set_integrator_limit_N(double limit_N) { pid_.set_integrator_limit_N(limit_N); }

  /// Parts of the last update [N] and its tracking error r_k − y_k [m].
  double last_feedback_N() const noexcept { return last_feedback_N_; }
  double last_feedforward_N() const noexcept { return last_feedforward_N_; }
  double last_force_demand_N() const noexcept { return last_feedback_N_ + last_feedforward_N_; }
  double last_error_m() const noexcept { return last_error_m_; }

  const PidController& pid() const noexcept { return pid_; }

 private:
  PidController pid_;
  FeedforwardParameters feedforward_;
  double last_feedback_N_ = 0.0;
  double last_feedforward_N_ = 0.0;
  double last_error_m_ = 0.0;
};

}  // namespace clm::control
