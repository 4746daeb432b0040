#include "daemon/control/envelope.hpp"

#include <algorithm>
#include <cmath>

#include "daemon/control/checks.hpp"

namespace clm::control {
namespace {

using detail::format_number;

/// Where a stop within `limits` from 0 comes to rest [m] when it starts at
/// `velocity_m_per_s` still accelerating at `acceleration_m_per_s2` the same
/// way: the worst state a move within the motion limits can be in. The stop
/// first has to take the acceleration away at its jerk, and gains a²/(2j) of
/// velocity meanwhile.
double stopping_distance_m(double velocity_m_per_s, double acceleration_m_per_s2, const StopLimits& limits) {
  ReferenceSample moving{};
  moving.velocity_m_per_s = velocity_m_per_s;
  moving.acceleration_m_per_s2 = acceleration_m_per_s2;
  return stopping_position_m(moving, limits);
}

}  // namespace

std::string check_envelope(const Machine& machine, const EnvelopeSettings& s) {
  const double m = machine.mass_kg;
  const double force_N = s.force_limit_N;
  if (!(m > 0.0) || !(force_N > 0.0) || !(s.period_s > 0.0)) {
    return "control.mass_kg " + format_number(m) + " kg, control.force_limit_N " + format_number(force_N) +
           " N and the period must be positive";
  }
  // 1. acceleration
  if (m * s.motion_limits.acceleration_m_per_s2 > kMoveForceShare * force_N) {
    return "motion.acceleration_m_per_s2 " + format_number(s.motion_limits.acceleration_m_per_s2) + " m/s^2 takes " +
           format_number(m * s.motion_limits.acceleration_m_per_s2) + " N on the " + format_number(m) +
           " kg translator, more than " + format_number(kMoveForceShare) + " of control.force_limit_N (" +
           format_number(kMoveForceShare * force_N) + " N)";
  }
  for (const auto& [key, limits] : {std::pair{"motion.stop_deceleration_m_per_s2", s.stop_limits},
                                    std::pair{"motion.quick_stop_deceleration_m_per_s2", s.quick_stop_limits}}) {
    if (m * limits.deceleration_m_per_s2 > kStopForceShare * force_N) {
      return std::string(key) + " " + format_number(limits.deceleration_m_per_s2) + " m/s^2 takes " +
             format_number(m * limits.deceleration_m_per_s2) + " N on the " + format_number(m) + " kg translator, more than " +
             format_number(kStopForceShare) + " of control.force_limit_N (" + format_number(kStopForceShare * force_N) + " N)";
    }
  }
  // 2. jerk
  const double max_jerk = force_N / (m * kMinForceRiseCycles * s.period_s);
  for (const auto& [key, jerk] : {std::pair{"motion.jerk_m_per_s3", s.motion_limits.jerk_m_per_s3},
                                  std::pair{"motion.stop_jerk_m_per_s3", s.stop_limits.jerk_m_per_s3},
                                  std::pair{"motion.quick_stop_jerk_m_per_s3", s.quick_stop_limits.jerk_m_per_s3}}) {
    if (jerk > max_jerk) {
      return std::string(key) + " " + format_number(jerk) + " m/s^3 asks the force to rise to control.force_limit_N in " +
             "fewer than " + format_number(kMinForceRiseCycles) + " cycles (at most " + format_number(max_jerk) + " m/s^3)";
    }
  }
  // 3. velocity
  const double half_span_m = 0.5 * (s.soft_limit_max_m - s.soft_limit_min_m);
  const double stop_m =
      stopping_distance_m(s.motion_limits.velocity_m_per_s, s.motion_limits.acceleration_m_per_s2, s.quick_stop_limits);
  if (stop_m > half_span_m) {
    return "motion.velocity_m_per_s " + format_number(s.motion_limits.velocity_m_per_s) +
           " m/s with motion.acceleration_m_per_s2 " + format_number(s.motion_limits.acceleration_m_per_s2) +
           " m/s^2: a quick stop from them (motion.quick_stop_deceleration_m_per_s2 " +
           format_number(s.quick_stop_limits.deceleration_m_per_s2) + " m/s^2, motion.quick_stop_jerk_m_per_s3 " +
           format_number(s.quick_stop_limits.jerk_m_per_s3) + " m/s^3) takes " + format_number(stop_m) +
           " m, more than half the span between the soft limits (" + format_number(half_span_m) + " m)";
  }
  // 4. feedforward
  const FeedforwardParameters& ff = s.feedforward;
  if (ff.mass_kg != 0.0 && (ff.mass_kg < m / kFeedforwardMassFactor || ff.mass_kg > m * kFeedforwardMassFactor)) {
    return "control.feedforward.mass_kg " + format_number(ff.mass_kg) + " kg: 0 or within a factor " +
           format_number(kFeedforwardMassFactor) + " of the translator's " + format_number(m) + " kg (control.mass_kg): [" +
           format_number(m / kFeedforwardMassFactor) + ", " + format_number(m * kFeedforwardMassFactor) + "] kg";
  }
  const double friction_N = std::fabs(ff.viscous_N_s_per_m) * s.motion_limits.velocity_m_per_s + std::fabs(ff.coulomb_N);
  if (friction_N > kFeedforwardForceShare * force_N) {
    return "control.feedforward: viscous " + format_number(ff.viscous_N_s_per_m) + " N*s/m at " +
           format_number(s.motion_limits.velocity_m_per_s) + " m/s plus Coulomb " + format_number(ff.coulomb_N) + " N make " +
           format_number(friction_N) + " N, more than " + format_number(kFeedforwardForceShare) + " of control.force_limit_N (" +
           format_number(kFeedforwardForceShare * force_N) + " N)";
  }
  // 5. following error
  const double inside_m = std::min(machine.stroke_max_m - s.soft_limit_max_m, s.soft_limit_min_m - machine.stroke_min_m);
  if (2.0 * s.following_error_limit_m > inside_m) {
    return "control.following_error_limit_m " + format_number(s.following_error_limit_m) +
           " m: the soft limits must lie inside the stroke [" + format_number(machine.stroke_min_m) + ", " +
           format_number(machine.stroke_max_m) + "] m by at least twice it (" + format_number(2.0 * s.following_error_limit_m) +
           " m), they lie inside by " + format_number(inside_m) + " m";
  }
  // 6. saturation
  if (s.saturation_time_limit_s > kMaxSaturationTime_s || s.saturation_time_limit_s < s.period_s) {
    return "control.saturation_time_limit_s " + format_number(s.saturation_time_limit_s) + " s: between one period (" +
           format_number(s.period_s) + " s) and " + format_number(kMaxSaturationTime_s) + " s";
  }
  // 7. loop
  const double lag_m = friction_N / s.pid.proportional_N_per_m;
  if (!(lag_m <= kLoopErrorShare * s.following_error_limit_m)) {
    return "control.bandwidth_hz: the position loop's k_p " + format_number(s.pid.proportional_N_per_m) +
           " N/m lets the feedforward's friction terms (" + format_number(friction_N) + " N: viscous " +
           format_number(ff.viscous_N_s_per_m) + " N*s/m at " + format_number(s.motion_limits.velocity_m_per_s) +
           " m/s plus Coulomb " + format_number(ff.coulomb_N) + " N) push the axis " + format_number(lag_m) +
           " m off its reference, more than control.following_error_limit_m (" +
           format_number(s.following_error_limit_m) + " m); raise the bandwidth or lower the feedforward";
  }
  return "";
}

}  // namespace clm::control
