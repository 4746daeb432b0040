#pragma once
// What a commutation law costs and whether its gains are those of a motor
// (docs/servod.md, "Files": "What a law may cost and mean"). Deterministic:
// the cost is counted from the shapes of the law, never timed, so a file is
// accepted or refused alike on every run and machine. No I/O.

#include <cstdint>
#include <span>
#include <string>

#include "commutation/classical.hpp"
#include "commutation/model.hpp"
#include "commutation/range_blend.hpp"

namespace clm {

// ---- evaluation cost, in multiply-add equivalents ---------------------------
// One multiply-add (a·b + c in double) is the unit. The elementary functions
// are weighted by what elementary.cpp does for them: tanh is a range
// reduction, a degree-12 polynomial by Estrin's scheme and a division
// (about 20 multiply-adds, the division counted as several); sin_cos a
// three-part reduction and two polynomials (about 40). The inverse (37) is
// counted from commutate_with_gain: the 3 × 3 normal matrix, its eigenvalues
// in closed form (a square root, an arc cosine and a cosine), a Cholesky solve
// and eq. (39) per coil set (Γ⁻¹ and the polar form of each setpoint).

inline constexpr std::int64_t kTanhMultiplyAdds = 20;
inline constexpr std::int64_t kSinCosMultiplyAdds = 40;
/// Inverse (37) and eq. (39): fixed part and per coil set.
inline constexpr std::int64_t kInverseMultiplyAdds = 300;
inline constexpr std::int64_t kInverseMultiplyAddsPerCoilSet = 80;
/// The physics part A·cos θ + B·sin θ of one coil set: 3 rows × 2 columns × 2.
inline constexpr std::int64_t kPhysicsMultiplyAdds = 12;
/// Per harmonic order: the angle-addition recurrence (angle_harmonics) up to
/// the highest order once; per coil set add_physics_harmonics' 3 rows ×
/// 2 columns × (cos, sin) per gain order and 3 rows × (cos, sin) per cogging
/// order.
inline constexpr std::int64_t kRecurrenceMultiplyAddsPerOrder = 4;
inline constexpr std::int64_t kGainHarmonicMultiplyAdds = 12;
inline constexpr std::int64_t kCoggingHarmonicMultiplyAdds = 6;
/// UniformCubicBasis::evaluate (clamp, floor, four cubic weights) once, and
/// per spline 3 rows × 4 coefficients.
inline constexpr std::int64_t kSplineBasisMultiplyAdds = 25;
inline constexpr std::int64_t kSplineMultiplyAdds = 12;
/// Classical law (12) per coil set: one angle (sin_cos), the setpoint's
/// polar form (an atan2 and a square root, counted as a second sin_cos) and
/// the force share.
inline constexpr std::int64_t kClassicalMultiplyAddsPerCoilSet = 2 * kSinCosMultiplyAdds + 20;

// ---- the budget ---------------------------------------------------------------
// Conservative rate: 2.5·10⁸ multiply-add equivalents per second, a quarter
// of what the development host did on the 70 × 64 PGNN that was found
// (3.3·10⁶ counted in 2.5–4 ms: about 10⁹ per second), so that a slower
// embedded CPU, cache misses and a loaded host still fit. Share: the law may
// take a tenth of the period; the rest of the cycle waits for feedback
// (loop.receive_window_fraction, 0.5 by default), runs the position loop and
// sends the setpoints. At 1 kHz the budget is 25 000.
inline constexpr double kConservativeMultiplyAddsPerSecond = 2.5e8;
inline constexpr double kLawShareOfPeriod = 0.1;

/// Multiply-add equivalents of one evaluation of `network`: n_i·n_{i−1}
/// multiply-adds per layer (biases are the sums' starting values) and one
/// tanh per hidden neuron. 0 for the empty network.
std::int64_t network_cost(const Network& network);

/// Multiply-add equivalents of one cycle of ModelCommutator on `model`:
/// the angle (sin_cos), per coil set the physics part, its harmonics and the
/// three networks (PGNN) or the basis once and three splines (spline); then
/// the inverse (37), all at the weights above.
std::int64_t model_law_cost(const ElectromagneticModel& model);

/// Multiply-add equivalents of one cycle of ClassicalCommutator.
std::int64_t classical_law_cost(int coil_sets);

/// RangeBlendedCommutator's own work in the margin, where it runs both laws:
/// Γ⁻¹ (a sin_cos) once, and per coil set the blend of two currents and the
/// setpoint's polar form (an atan2 and a square root, counted as a sin_cos).
inline constexpr std::int64_t kBlendMultiplyAdds = kSinCosMultiplyAdds + 10;
inline constexpr std::int64_t kBlendMultiplyAddsPerCoilSet = kSinCosMultiplyAdds + 10;

/// Multiply-add equivalents of one cycle of RangeBlendedCommutator on `model`
/// where it costs most (in the margin): both laws and the blend.
std::int64_t blended_law_cost(const ElectromagneticModel& model);

/// What one cycle's law may cost at `loop_rate_hz`:
/// kConservativeMultiplyAddsPerSecond · kLawShareOfPeriod / loop_rate_hz.
std::int64_t law_cost_budget(double loop_rate_hz);

// ---- plausibility of the gains --------------------------------------------------
// A coil set's motor constant as a law sees it must lie within a factor
// kGainFactorLimit of the drive's nominal k̂_d (motor file,
// drive.commutation.motor_constant_N_per_A). Real coil sets differ from the
// manufacturer's value by a few percent (the simulated motors: 60.1–61.6 N/A
// against 67), parasitics (field harmonics, magnet track) by a few percent
// more along the stroke; what clm commission wrote for the three simulated
// motors lies within 0.53–1.00 of the nominal (docs/servod.md). A factor 10
// leaves at least a factor 5 of margin there and still refuses a zeroed,
// denormal or absurdly scaled coil set.
inline constexpr double kGainFactorLimit = 10.0;
/// A model's range is sampled at this many points per pole pitch (the gains
/// vary with the electrical angle), at most kMaxGainSamples in all, both ends
/// included.
inline constexpr int kGainSamplesPerPolePitch = 32;
inline constexpr int kMaxGainSamples = 8192;

/// The motor constant of one coil set at one position as a model sees it:
/// the driving force per ampere of amplitude of balanced sinusoidal currents
/// in phase with it, sqrt(K_ya² − K_ya·K_yb + K_yb²) of the reduced gain's
/// driving-force row [N/A]. Exactly k for the classical gain (7) at every
/// position.
double driving_force_gain_N_per_A(const CoilGain& gain) noexcept;

/// What a law and its limits are checked against.
struct LawLimits {
  double loop_rate_hz = 1000.0;
  double nominal_motor_constant_N_per_A = 0.0;  ///< drive.commutation.motor_constant_N_per_A
  double stroke_min_m = 0.0;                    ///< motor.stroke_min_m
  double stroke_max_m = 0.0;                    ///< motor.stroke_max_m
};

enum class LawVerdict {
  kAccepted,
  kTooCostly,          ///< value: cost, limit: budget [multiply-add equivalents]
  kGainNotFinite,      ///< coil set's motor constant NaN or infinite
  kGainOutOfRange,     ///< value: the motor constant, lower/upper: the range [N/A]
};

/// The outcome of a check: the first fault found. coil_set is 1-based;
/// position_m is NaN for a calibration (no position).
struct LawCheck {
  LawVerdict verdict = LawVerdict::kAccepted;
  int coil_set = 0;
  double position_m = 0.0;
  double value = 0.0;
  double lower = 0.0;
  double upper = 0.0;
  double loop_rate_hz = 0.0;
  bool accepted() const { return verdict == LawVerdict::kAccepted; }
};

/// One line, with the value and the limit: "costs 3352936 multiply-adds per
/// cycle, budget 25000 at 1000 Hz", "coil set 2 at y = 0.0125 m: motor
/// constant 0 N/A outside [6.7, 670] N/A". Empty when accepted.
std::string describe(const LawCheck& check);

/// The model's law as if it were used unblended on the whole stroke: its
/// cost, then every coil set's driving_force_gain_N_per_A on a grid over the
/// stroke (kGainSamplesPerPolePitch), from its lower end, coil set by coil
/// set at each point. A model extrapolates beyond its data, so this refuses
/// most commissioned PGNNs; the daemon uses check_blended_law.
LawCheck check_model_law(const ElectromagneticModel& model, const LawLimits& limits);

/// The law the daemon uses for `model` (RangeBlendedCommutator with the
/// classical constants `outside`), on the whole stroke: its cost
/// (blended_law_cost), then at each grid point of the stroke the gains of
/// every law that drives the axis there: the model's where its weight is
/// above 0 (its identified range and the margin), each coil set's k̂ of
/// `outside` where it is below 1. `outside` must have one entry per coil set.
LawCheck check_blended_law(const ElectromagneticModel& model, std::span<const ClassicalEstimate> outside,
                           const LawLimits& limits);

/// Cost, then each coil set's calibrated motor constant.
LawCheck check_classical_law(std::span<const ClassicalEstimate> estimates, const LawLimits& limits);

}  // namespace clm
