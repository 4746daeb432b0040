#pragma once
// The live split of a tracking error by the commutation's own frequencies
// (docs/commissioning.md, "The error budget"). A commutation error is a force
// that repeats with position, on its own (cogging) and in proportion to the
// force asked for (a gain and phase error of the law, eq. (7)):
// ΔF = c(y) + g(y)·F*. Both vary as the pole pitch's harmonics (in time at
// multiples of velocity ÷ pole pitch) and more slowly along the stroke
// (cogging, the magnet track's strength and orientation). Through the loop
// ΔF becomes a tracking error e_c = G·ΔF(t), G the response of the tracking
// error to a force at the motor (the mass 1/(m s²) closed by the PID as it
// runs, the force held over each period). c and g are written in cos and
// sin(2πn·y/d_m), n = 1..N, and a uniform cubic B-spline over the recorded
// positions with knots an eighth of the pitch apart. Each shape, and each
// shape times the feedforward part of F* (eq. 40), passed through G is a
// regressor: g times the feedback's part is left out, a second-order term
// that would also make the feedback's reaction to any disturbance look like
// a gain error. The least-squares fit of the recorded tracking error on
// them is the part the commutation causes, the residual the rest (disturbance, noise, a direction-dependent force, the loop's own
// following of the reference). It needs no truth, so it runs on a live
// recording. Numerical only: no I/O.

#include <span>

#include "daemon/control/position_controller.hpp"

namespace clm::control {

struct TrackingSplit {
  double total_m2 = 0.0;        ///< mean square of the tracking error [m²]
  double commutation_m2 = 0.0;  ///< what its fit on the commutation's frequencies explains: total − rest [m²]
  double rest_m2 = 0.0;         ///< mean square of the residual [m²]; the two add up to the total
  int harmonics = 0;            ///< N
  int regressors = 0;           ///< twice (2N and the B-spline's functions)
};

/// The harmonics of the pole pitch the split fits: the orders a commutation
/// error of a three-phase motor has (1, 2, the 5th and 7th of the magnets,
/// the 6th of cogging) and those between.
inline constexpr int kTrackingSplitHarmonics = 8;
/// The B-spline's knot spacing, in pole pitches.
inline constexpr double kTrackingSplitKnotPitches = 0.125;
/// The fit's ridge, relative to each column's sum of squares over the run.
inline constexpr double kTrackingSplitRidge = 1e-6;

/// The split of `tracking_error_m` (r − y per cycle) recorded at
/// `position_m` with the feedforward part `feedforward_N` of the force demand, on a loop of
/// `gains` at `period_s` around a translator of `mass_kg`. Throws std::invalid_argument when the spans' sizes differ,
/// when there are fewer than four samples per regressor, or when the pitch,
/// the mass, the period or `harmonics` is not positive, or a position is not finite.
TrackingSplit split_tracking_error(std::span<const double> position_m, std::span<const double> feedforward_N,
                                   std::span<const double> tracking_error_m, double pole_pitch_m, const PidGains& gains, double mass_kg, double period_s,
                                   int harmonics = kTrackingSplitHarmonics);

}  // namespace clm::control
