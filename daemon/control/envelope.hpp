#pragma once
// The safe envelope of an axis (docs/servod.md, "The safe envelope"): which
// combinations of limits, gains and feedforward are safe on a machine of a
// given mass and stroke. Each setting may lie within its own range and the
// set still drive the translator into its end stop (a feedforward mass 667
// times the translator's, a following-error limit of 1 m and a saturation
// time of 10 s did); the daemon checks the whole set at start-up and at every
// run-time change. Pure: no I/O, no state.
//
// The relations, each with the reasoning of its bound:
//  1. acceleration: the translator's mass at the largest acceleration a move
//     may ask for takes at most kMoveForceShare of the force limit (the rest
//     is the feedback's); at the stop's and the quick stop's deceleration at
//     most kStopForceShare: a stop the motor cannot deliver is no stop.
//  2. jerk: the force may not be asked to rise from 0 to the force limit in
//     fewer than kMinForceRiseCycles cycles (mass · jerk ≤ F_limit /
//     (kMinForceRiseCycles · period)).
//  3. velocity: from the largest velocity a quick stop comes to rest within
//     half the span between the soft limits.
//  4. feedforward: its mass is 0 (none) or within a factor
//     kFeedforwardMassFactor of the translator's; viscous friction at the
//     largest velocity plus Coulomb friction take at most
//     kFeedforwardForceShare of the force limit.
//  5. following error: the soft limits lie inside the stroke by at least
//     twice the following-error limit (the axis may lag its reference by the
//     limit before fault 203 latches, and overshoot as much again while the
//     quick stop takes over); the reference itself never plans a stop beyond
//     a soft limit (move admission, the cycle's approach guard).
//  6. saturation: the force may stay at its limit for at most
//     kMaxSaturationTime_s before fault 204, and at least one period.
//  7. loop: the feedforward's friction terms in full (viscous at the largest
//     velocity plus Coulomb), a force that pushes along the reference's
//     velocity for as long as a move or a stop lasts, held by the position
//     loop's stiffness k_p, lag the reference by at most kLoopErrorShare of
//     the following-error limit. A loop too soft for its feedforward is
//     pushed away by it: a Coulomb feedforward of 112 N against a 1 Hz loop
//     (k_p 330 N/m) ran the translator 12 cm, through a seconds-long quick
//     stop, into its end stop. (The mass term acts only while the reference
//     accelerates; relation 4 bounds it, and a lag it causes latches fault
//     203 like any other.)

#include <string>

#include "daemon/control/position_controller.hpp"
#include "daemon/control/stop_profile.hpp"
#include "daemon/control/trajectory.hpp"

namespace clm::control {

/// What the envelope is derived from: the machine, fixed at start-up.
struct Machine {
  double mass_kg = 15.0;        ///< the translator's mass (control.mass_kg) [kg]
  double stroke_min_m = -0.12;  ///< lower end of travel (motor.stroke_min_m) [m]
  double stroke_max_m = 0.12;   ///< upper end of travel (motor.stroke_max_m) [m]
};

/// The settings the envelope bounds.
struct EnvelopeSettings {
  double period_s = 1e-3;
  double soft_limit_min_m = -0.1;
  double soft_limit_max_m = 0.1;
  double following_error_limit_m = 1e-3;
  double force_limit_N = 500.0;
  double saturation_time_limit_s = 0.05;
  MotionLimits motion_limits{0.5, 10.0, 2000.0};
  StopLimits stop_limits{10.0, 2000.0};
  StopLimits quick_stop_limits{10.0, 2000.0};
  FeedforwardParameters feedforward{};
  PidGains pid{0.0, 0.0, 0.0, 1.0};
};

inline constexpr double kMoveForceShare = 0.5;
inline constexpr double kStopForceShare = 0.8;
inline constexpr double kMinForceRiseCycles = 2.0;
inline constexpr double kFeedforwardMassFactor = 2.0;
inline constexpr double kFeedforwardForceShare = 0.5;
inline constexpr double kMaxSaturationTime_s = 1.0;
inline constexpr double kLoopErrorShare = 1.0;

/// "" when `settings` lie inside the envelope of `machine`, else the first
/// relation violated, in one line with both sides' values, e.g.
/// "control.following_error_limit_m 1 m: the soft limits must lie inside the
/// stroke by at least twice it (2 m), they lie inside by 0.01 m".
std::string check_envelope(const Machine& machine, const EnvelopeSettings& settings);

}  // namespace clm::control
