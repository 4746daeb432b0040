#include "daemon/control/stop_profile.hpp"

#include <cmath>

#include "daemon/control/checks.hpp"

namespace clm::control {
namespace {

bool finite(const ReferenceSample& s) noexcept {
  return std::isfinite(s.position_m) && std::isfinite(s.velocity_m_per_s) && std::isfinite(s.acceleration_m_per_s2);
}

}  // namespace

ReferenceSample StopProfile::advance(const ReferenceSample& from, double jerk_m_per_s3, double t_s) noexcept {
  ReferenceSample s;
  s.position_m = from.position_m + from.velocity_m_per_s * t_s + from.acceleration_m_per_s2 * t_s * t_s / 2.0 +
                 jerk_m_per_s3 * t_s * t_s * t_s / 6.0;
  s.velocity_m_per_s = from.velocity_m_per_s + from.acceleration_m_per_s2 * t_s + jerk_m_per_s3 * t_s * t_s / 2.0;
  s.acceleration_m_per_s2 = from.acceleration_m_per_s2 + jerk_m_per_s3 * t_s;
  s.jerk_m_per_s3 = jerk_m_per_s3;
  return s;
}

StopProfile StopProfile::plan(const ReferenceSample& start, const StopLimits& limits) noexcept {
  StopProfile p;
  p.start_ = start;
  p.start_.jerk_m_per_s3 = 0.0;
  p.rest_position_m_ = start.position_m;
  const double j = limits.jerk_m_per_s3;
  const double a_max = limits.deceleration_m_per_s2;
  if (!finite(start) || !(j > 0.0 && std::isfinite(j)) || !(a_max > 0.0 && std::isfinite(a_max))) {
    p.start_.velocity_m_per_s = 0.0;
    p.start_.acceleration_m_per_s2 = 0.0;
    return p;
  }
  p.valid_ = true;
  auto add = [&p](double duration_s, double jerk) {
    if (duration_s > 0.0) p.segments_[p.segment_count_++] = {duration_s, jerk};
  };
  ReferenceSample s = p.start_;
  // An acceleration beyond the limit is first brought back to it.
  if (std::fabs(s.acceleration_m_per_s2) > a_max) {
    const double jerk = -detail::sign(s.acceleration_m_per_s2) * j;
    const double t = (std::fabs(s.acceleration_m_per_s2) - a_max) / j;
    add(t, jerk);
    s = advance(s, jerk, t);
    s.acceleration_m_per_s2 = detail::sign(s.acceleration_m_per_s2) * a_max;
  }
  // Velocity left after taking the acceleration straight to zero.
  const double a0 = s.acceleration_m_per_s2;
  const double v_left = s.velocity_m_per_s + a0 * std::fabs(a0) / (2.0 * j);
  const double d = detail::sign(v_left);
  if (d == 0.0) {
    add(std::fabs(a0) / j, -detail::sign(a0) * j);
  } else {
    // In the frame where v_left > 0: brake at −a_p.
    const double v = d * s.velocity_m_per_s;
    const double a = d * a0;
    double a_peak = a_max;
    double hold_s = (v + (a * a - 2.0 * a_max * a_max) / (2.0 * j)) / a_max;
    if (hold_s < 0.0) {
      a_peak = std::sqrt(v * j + a * a / 2.0);
      hold_s = 0.0;
    }
    add((a + a_peak) / j, -d * j);
    add(hold_s, 0.0);
    add(a_peak / j, d * j);
  }
  for (std::size_t i = 0; i < p.segment_count_; ++i) p.duration_s_ += p.segments_[i].duration_s;
  // Integrate the segments once for the rest position.
  ReferenceSample end = p.start_;
  for (std::size_t i = 0; i < p.segment_count_; ++i) end = advance(end, p.segments_[i].jerk_m_per_s3, p.segments_[i].duration_s);
  p.rest_position_m_ = end.position_m;
  return p;
}

ReferenceSample StopProfile::sample(double t_s) const noexcept {
  if (!(t_s > 0.0)) return start_;
  ReferenceSample rest;
  rest.position_m = rest_position_m_;
  // From duration_s() on exactly at rest (the segment walk below could leave a
  // rounding residue of the last segment).
  if (t_s >= duration_s_) return rest;
  ReferenceSample s = start_;
  for (std::size_t i = 0; i < segment_count_; ++i) {
    const Segment& segment = segments_[i];
    if (t_s < segment.duration_s) return advance(s, segment.jerk_m_per_s3, t_s);
    s = advance(s, segment.jerk_m_per_s3, segment.duration_s);
    t_s -= segment.duration_s;
  }
  return rest;
}

double stopping_position_m(const ReferenceSample& start, const StopLimits& limits) noexcept {
  return StopProfile::plan(start, limits).rest_position_m();
}

}  // namespace clm::control
