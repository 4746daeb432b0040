#pragma once
// Position-based identification of the driving direction, for axes without
// a force sensor (paper Remarks 2.1 and 4.3; docs/commutation.md, "Without
// a force sensor"): the y-row of the spline model of one coil set (A_y, B_y
// and the coefficients of the two gain columns and the cogging) identified
// jointly with the mechanics of the translator from its positions alone.
//
// Between two cycles the drive holds the setpoint of the first, so with
// piecewise-constant forces the second difference of three positions is
//   (y_{k+1} − 2 y_k + y_{k−1}) / T² = [½ (F_{k−1} + F_k) − f_v v_k − f_d tanh(v_k/v_d)] / m,
// F_j the electromagnetic driving force of setpoint j over the period after
// row j, v_k = (y_{k+1} − y_{k−1}) / 2T. The second difference weighs the
// acceleration over the two periods as a hat peaking at row k; a drive's
// current loop and a delay from setpoint to force move part of each
// setpoint's force into later periods, and the ½, ½ become the hat's weights
// of each setpoint's force over the periods it acts in (PairingWeights). Linear in every unknown over m, with
// the measured acceleration as the target (so that the positions' noise
// stays out of the regressors). Bearing Coulomb friction and the
// direction-dependent force C·tanh(ẏ/v_c) act alike on the motion and are
// one term f_d here; neither enters the law. From positions only K/m is
// observable: a given mass fixes the scale, otherwise the mass that brings
// A_y, B_y closest to the drive's nominal commutation (k̂_d, ζ̂_d) does. No I/O.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "commutation/bspline.hpp"
#include "commutation/current_loop_compensation.hpp"
#include "commutation/types.hpp"

namespace clm::identification {

/// One run of consecutive cycles of one coil set, driven alone.
struct MotionRun {
  Eigen::VectorXd time_s;      ///< equal steps (the control period)
  Eigen::VectorXd position_m;  ///< measured at each row
  /// [i_a; i_b] that the setpoint computed at each row drives over the
  /// period after it, at that period's middle position (a magnitude/phase
  /// drive commutates with the true position as the translator moves).
  Eigen::Matrix<double, 2, Eigen::Dynamic> currents_A;
  /// The same setpoint's [i_a; i_b] at the middle position of the period
  /// after its own, where a current loop's lag or a delay carries part of its
  /// force (a magnitude/phase drive commutates it there). Empty: the
  /// currents do not depend on the position (a phase-current drive), the
  /// same as currents_A.
  Eigen::Matrix<double, 2, Eigen::Dynamic> currents_next_A;
};

/// How the second difference of positions at row k weighs the force of the
/// setpoints of rows k, k − 1, …, k − count + 1 (docs/commutation.md,
/// "Without a force sensor"): the integral of the hat over the two periods
/// around row k times the share of each setpoint's force at each instant. A
/// drive's current loop, compensated so that the currents follow the law
/// along the motion (CurrentLoopCompensation), passes each change of setpoint
/// through its first-order lag 1 − e^(−ω_c t); `delay_s` (setpoint to force,
/// plus the encoder's measurement delay) shifts the changes against the
/// samples. `own[n]` is setpoint k − n's weight inside its own period,
/// `later[n]` inside the periods after it. The weights add up to one; an ideal
/// undelayed drive gives own = {½, ½}, later = 0. A tail of less than 10⁻⁶,
/// or beyond kMaxSetpoints periods (a loop slower than the cycle), is added
/// to the oldest setpoint's weight.
struct PairingWeights {
  static constexpr int kMaxSetpoints = 6;
  std::array<double, kMaxSetpoints> own{}, later{};
  int count = 0;  ///< setpoints with a weight, newest first
};
/// Throws std::invalid_argument for a period not positive, a negative or
/// non-finite delay, or a loop CurrentLoopModel::validate() refuses.
PairingWeights pairing_weights(const CurrentLoopModel& loop, double delay_s, double period_s);

struct MotionFitOptions {
  /// The force scale, which positions do not determine, comes from the
  /// first given of: the translator's mass (> 0), the friction (viscous_N_s_per_m
  /// and/or direction_N > 0: the mass that makes the identified friction
  /// these), or the drive's nominal commutation.
  double mass_kg = 0.0;             ///< > 0: the translator's mass, known; 0: identified
  double smoothing = 1e-6;          ///< roughness weight, relative to the largest diagonal of the normal matrix
  /// The drive's nominal commutation (k̂_d, ζ̂_d): the scale when the mass is not given.
  DriveCommutation drive;
  double direction_smoothing_m_per_s = 1e-3;  ///< v_d of f_d·tanh(v/v_d)
  /// Rows slower than this are left out: near standstill static friction
  /// takes any value up to its limit, which no smooth friction law follows.
  double min_speed_m_per_s = 5e-3;
  double viscous_N_s_per_m = 0.0;  ///< > 0: the viscous friction f_v, known
  double direction_N = 0.0;        ///< > 0: f_d (Coulomb friction and the direction-dependent force), known
  /// The drive's current loop (the motor file's drive.current_loop) and the
  /// delay from setpoint to force plus the encoder's: how each setpoint's
  /// force spreads over the periods (PairingWeights).
  CurrentLoopModel current_loop;
  double delay_s = 0.0;

  /// Where the force scale comes from: the one place that reads the rule.
  enum class Scale { kMass, kFriction, kNominal };
  bool friction_given() const noexcept { return viscous_N_s_per_m > 0.0 || direction_N > 0.0; }
  Scale scale() const noexcept {
    return mass_kg > 0.0 ? Scale::kMass : friction_given() ? Scale::kFriction : Scale::kNominal;
  }
  /// Throws std::invalid_argument "<what>: ..." for a negative or non-finite
  /// mass, smoothing, minimum speed or friction, v_d not positive, or a mass
  /// and a friction given together (each fixes the scale).
  void validate(const char* what) const;
};

struct MotionFit {
  Eigen::Matrix<double, 1, 2> a_y = Eigen::Matrix<double, 1, 2>::Zero();  ///< A_y [N/A]
  Eigen::Matrix<double, 1, 2> b_y = Eigen::Matrix<double, 1, 2>::Zero();  ///< B_y [N/A]
  Eigen::RowVectorXd column_a, column_b, cogging;  ///< y-row spline coefficients [N/A, N/A, N]
  double mass_kg = 0.0;
  double viscous_N_s_per_m = 0.0;
  double direction_N = 0.0;      ///< f_d: Coulomb friction and the direction-dependent force together
  double residual_rms_N = 0.0;   ///< of the force balance, over the rows used
  Eigen::Index rows = 0;         ///< second differences used

  /// The same motor at another mass: every force term scaled by mass_kg/mass.
  MotionFit scaled_to_mass(double mass_kg) const;

  /// K_y(y) [N/A] and F_cog,y(y) [N] of the fit on `basis`.
  Eigen::Matrix<double, 1, 2> gain(double position_m, double pole_pitch_m, const UniformCubicBasis& basis) const;
  double cogging_N(double position_m, const UniformCubicBasis& basis) const;
};

/// Fits MotionFit over `runs` on `basis`. Throws std::invalid_argument for
/// runs of unequal steps or lengths, fewer than 10 usable rows, a singular
/// problem, a mass and a friction both given, or a scale that gives no
/// positive mass.
MotionFit fit_driving_direction_from_motion(const std::vector<MotionRun>& runs, double pole_pitch_m,
                                            const UniformCubicBasis& basis, const MotionFitOptions& options);

/// RMS of the force balance of `fit` over the rows of `runs` that the fit
/// would use [N] (held-out scoring); 0 rows give NaN.
double motion_residual_rms_N(const MotionFit& fit, const std::vector<MotionRun>& runs, double pole_pitch_m,
                             const UniformCubicBasis& basis, const MotionFitOptions& options);

/// The translator's mass from the same experiments identified without and
/// with a known payload mounted (docs/commissioning.md, "The force scale
/// from a known payload"). Per kilogram (each fit's terms over its mass_kg:
/// fits made with a given mass, on `basis`) the gains K(y) and the cogging
/// F_cog(y) are K/m without and K/(m + payload) with it, the same motor;
/// their least-squares ratio r at `positions_m` (where the experiments ran)
/// over every coil set gives m = payload/(r − 1). The functions are
/// compared, not the coefficients: a spline column can take up part of
/// the sinusoid A_y, B_y describe. The friction is left out: a payload's
/// weight on the bearing changes it. Throws std::invalid_argument for lists
/// of different lengths, no positions, a payload not positive and finite,
/// or a ratio that is not above 1 + 10⁻³ (the payload made no difference the
/// fits resolve).
struct PayloadMass {
  double mass_kg = 0.0;  ///< m, the translator without the payload
  double ratio = 0.0;    ///< r = (m + payload)/m as identified
};
PayloadMass mass_from_payload(const std::vector<MotionFit>& without, const std::vector<MotionFit>& with,
                              double payload_kg, const Eigen::VectorXd& positions_m, double pole_pitch_m,
                              const UniformCubicBasis& basis);

/// One mass for several coil sets (one translator) when options.mass_kg is
/// not given: the one that brings their per-kilogram friction together
/// closest to the friction given, else their per-kilogram A_y, B_y closest
/// to the drive's nominal commutation.
double common_mass_kg(const std::vector<MotionFit>& fits, const MotionFitOptions& options);

}  // namespace clm::identification
