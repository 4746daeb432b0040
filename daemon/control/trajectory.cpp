#include "daemon/control/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "daemon/control/checks.hpp"

namespace clm::control {

namespace {

constexpr const char* kMoveContext = "ThirdOrderMove::plan";

void check_limits(const char* context, const MotionLimits& limits) {
  detail::require_positive_finite(context, "velocity_m_per_s", limits.velocity_m_per_s);
  detail::require_positive_finite(context, "acceleration_m_per_s2", limits.acceleration_m_per_s2);
  detail::require_positive_finite(context, "jerk_m_per_s3", limits.jerk_m_per_s3);
}

}  // namespace

ThirdOrderMove ThirdOrderMove::plan(double start_m, double end_m, const MotionLimits& limits) {
  detail::require_finite(kMoveContext, "start_m", start_m);
  detail::require_finite(kMoveContext, "end_m", end_m);
  check_limits(kMoveContext, limits);

  ThirdOrderMove move;
  move.start_m_ = start_m;
  move.end_m_ = end_m;
  move.limits_ = limits;
  const double distance_m = std::abs(end_m - start_m);
  if (distance_m == 0.0) return move;  // zero-length: duration 0, at rest
  move.direction_ = end_m > start_m ? 1.0 : -1.0;

  const double v_max = limits.velocity_m_per_s;
  const double a_max = limits.acceleration_m_per_s2;
  const double j_max = limits.jerk_m_per_s3;
  // Peak velocity from which a_max is reached during the acceleration phase.
  const double a_reach_velocity = a_max * a_max / j_max;
  // Distance of an acceleration phase from rest to peak velocity vp plus the
  // mirrored deceleration phase, without a constant-velocity segment.
  const auto distance_to_peak = [&](double vp) {
    return vp >= a_reach_velocity ? vp * (vp / a_max + a_max / j_max)  // trapezoidal acceleration
                                  : 2.0 * vp * std::sqrt(vp / j_max);  // triangular acceleration
  };

  double peak_velocity = v_max;
  double cruise_time_s = 0.0;
  if (distance_to_peak(v_max) <= distance_m) {
    cruise_time_s = (distance_m - distance_to_peak(v_max)) / v_max;
  } else if (distance_m >= 2.0 * a_max * a_max * a_max / (j_max * j_max)) {
    // a_max reached, v_max not: vp² /a + vp·a/j = D, root in cancellation-free form.
    peak_velocity = 2.0 * distance_m * a_max /
                    (a_reach_velocity + std::sqrt(a_reach_velocity * a_reach_velocity + 4.0 * distance_m * a_max));
  } else {
    // Neither reached: D = 2·j·Tj³.
    const double jerk_time_s = std::cbrt(distance_m / (2.0 * j_max));
    peak_velocity = j_max * jerk_time_s * jerk_time_s;
  }

  if (peak_velocity >= a_reach_velocity) {
    move.jerk_time_s_ = a_max / j_max;
    move.constant_acceleration_time_s_ = std::max(0.0, peak_velocity / a_max - a_max / j_max);
  } else {
    move.jerk_time_s_ = std::sqrt(peak_velocity / j_max);
    move.constant_acceleration_time_s_ = 0.0;
  }
  move.peak_velocity_m_per_s_ = peak_velocity;
  move.peak_acceleration_m_per_s2_ = j_max * move.jerk_time_s_;
  move.duration_s_ = 4.0 * move.jerk_time_s_ + 2.0 * move.constant_acceleration_time_s_ + cruise_time_s;
  return move;
}

ReferenceSample ThirdOrderMove::first_half(double t_s) const noexcept {
  const double j = limits_.jerk_m_per_s3;
  const double tj = jerk_time_s_;
  const double ta = constant_acceleration_time_s_;
  const double a_peak = j * tj;
  // Segment 1: jerk +j.
  if (t_s < tj) {
    return {j * t_s * t_s * t_s / 6.0, 0.5 * j * t_s * t_s, j * t_s, j};
  }
  const double v1 = 0.5 * j * tj * tj;
  const double d1 = j * tj * tj * tj / 6.0;
  // Segment 2: constant acceleration.
  if (t_s < tj + ta) {
    const double tau = t_s - tj;
    return {d1 + v1 * tau + 0.5 * a_peak * tau * tau, v1 + a_peak * tau, a_peak, 0.0};
  }
  const double v2 = v1 + a_peak * ta;
  const double d2 = d1 + v1 * ta + 0.5 * a_peak * ta * ta;
  // Segment 3: jerk −j down to zero acceleration.
  if (t_s < 2.0 * tj + ta) {
    const double tau = t_s - tj - ta;
    return {d2 + v2 * tau + 0.5 * a_peak * tau * tau - j * tau * tau * tau / 6.0,
            v2 + a_peak * tau - 0.5 * j * tau * tau, a_peak - j * tau, -j};
  }
  const double v3 = v2 + a_peak * tj - 0.5 * j * tj * tj;
  const double d3 = d2 + v2 * tj + 0.5 * a_peak * tj * tj - j * tj * tj * tj / 6.0;
  // Segment 4 (first half of it): constant velocity.
  const double tau = t_s - 2.0 * tj - ta;
  return {d3 + v3 * tau, v3, 0.0, 0.0};
}

std::array<JerkSegment, 7> ThirdOrderMove::segments() const noexcept {
  const double j = direction_ * limits_.jerk_m_per_s3;
  const double a = direction_ * peak_acceleration_m_per_s2_;
  const double t1 = jerk_time_s_;
  const double t2 = jerk_time_s_ + constant_acceleration_time_s_;
  const double t3 = 2.0 * jerk_time_s_ + constant_acceleration_time_s_;
  const double t = duration_s_;
  if (direction_ == 0.0) return {};
  return {{{0.0, t1, j, 0.0},
           {t1, t2, 0.0, a},
           {t2, t3, -j, a},
           {t3, t - t3, 0.0, 0.0},
           {t - t3, t - t2, -j, 0.0},
           {t - t2, t - t1, 0.0, -a},
           {t - t1, t, j, -a}}};
}

ReferenceSample ThirdOrderMove::sample(double t_s) const noexcept {
  if (t_s < 0.0) return {start_m_, 0.0, 0.0, 0.0};
  if (t_s >= duration_s_) return {end_m_, 0.0, 0.0, 0.0};
  const double s = direction_;
  if (t_s <= 0.5 * duration_s_) {
    const ReferenceSample along = first_half(t_s);
    return {start_m_ + s * along.position_m, s * along.velocity_m_per_s, s * along.acceleration_m_per_s2,
            s * along.jerk_m_per_s3};
  }
  // Second half: the first half mirrored in time about the midpoint,
  // r(t) = r_end − (r(T − t) − r_start); velocity and jerk are even, the
  // acceleration is odd.
  const ReferenceSample along = first_half(duration_s_ - t_s);
  return {end_m_ - s * along.position_m, s * along.velocity_m_per_s, -s * along.acceleration_m_per_s2,
          s * along.jerk_m_per_s3};
}

MoveProgram::MoveProgram(double start_m, std::vector<ProgramStep> steps)
    : start_m_(start_m), steps_(std::move(steps)) {
  detail::require_finite("MoveProgram", "start_m", start_m);
  moves_.reserve(steps_.size());
  step_start_s_.reserve(steps_.size());
  double position_m = start_m;
  double time_s = 0.0;
  for (std::size_t i = 0; i < steps_.size(); ++i) {
    const ProgramStep& step = steps_[i];
    const std::string context = "MoveProgram step " + std::to_string(i + 1);
    try {
      moves_.push_back(ThirdOrderMove::plan(position_m, step.target_m, step.limits));
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument(context + ": " + error.what());
    }
    if (!(step.dwell_s >= 0.0) || !std::isfinite(step.dwell_s)) {
      throw std::invalid_argument(context + ": dwell_s must be finite and >= 0, got " +
                                  detail::format_number(step.dwell_s));
    }
    step_start_s_.push_back(time_s);
    time_s += moves_.back().duration_s() + step.dwell_s;
    position_m = step.target_m;
  }
  duration_s_ = time_s;
}

ReferenceSample MoveProgram::sample(double t_s) const noexcept {
  if (moves_.empty() || t_s < 0.0) return {start_m_, 0.0, 0.0, 0.0};
  // Last step whose move has begun; step_start_s_[0] = 0 ≤ t_s.
  const auto after = std::upper_bound(step_start_s_.begin(), step_start_s_.end(), t_s);
  const auto index = static_cast<std::size_t>(std::max<std::ptrdiff_t>(after - step_start_s_.begin() - 1, 0));
  // During the dwell the move's own sample() returns its end at rest.
  return moves_[index].sample(t_s - step_start_s_[index]);
}

MotionLimits fig8_limits(double velocity_m_per_s) { return {velocity_m_per_s, 1.0, 1000.0}; }

namespace {

void append_back_and_forth(std::vector<ProgramStep>& steps, double velocity_m_per_s) {
  constexpr double kLeft_m = -0.1;
  constexpr double kRight_m = 0.1;
  constexpr double kDwell_s = 0.25;
  steps.push_back({kRight_m, fig8_limits(velocity_m_per_s), kDwell_s});
  steps.push_back({kLeft_m, fig8_limits(velocity_m_per_s), kDwell_s});
}

}  // namespace

MoveProgram fig8_program() {
  std::vector<ProgramStep> steps;
  for (const double velocity_m_per_s : {0.025, 0.075, 0.15}) append_back_and_forth(steps, velocity_m_per_s);
  return MoveProgram(-0.1, std::move(steps));
}

MoveProgram fig8_program_at(double velocity_m_per_s) {
  detail::require_positive_finite("fig8_program_at", "velocity_m_per_s", velocity_m_per_s);
  std::vector<ProgramStep> steps;
  append_back_and_forth(steps, velocity_m_per_s);
  return MoveProgram(-0.1, std::move(steps));
}

}  // namespace clm::control
