#pragma once
// Jerk-limited stop from any state of motion: the reference's present
// position, velocity and acceleration are brought to rest (v = 0, a = 0) in
// minimum time within an acceleration and a jerk limit, the way a
// trajectory generator with online input (ruckig's velocity interface) brakes.
//
// In the frame where the velocity left after taking the acceleration to zero
// at once is positive, the profile has three segments of constant jerk:
//   1. jerk −j: the acceleration goes from a₀ to −a_p;
//   2. jerk 0: it stays at −a_p (absent when a_p < a_max);
//   3. jerk +j: it returns to 0, and the velocity reaches 0 with it.
// a_p = a_max when the velocity to remove is large enough to reach it, else
// a_p = √(v₀·j + a₀²/2). An acceleration beyond the limit at the start is
// first brought back within it (an extra segment). Planning and sampling are
// noexcept and do not allocate, so the cycle may plan a stop itself.

#include <array>
#include <cstddef>

#include "daemon/control/trajectory.hpp"

namespace clm::control {

/// The limits of a stop. Both positive and finite.
struct StopLimits {
  double deceleration_m_per_s2;  ///< |a| ≤ this while stopping [m/s²]
  double jerk_m_per_s3;          ///< |j| ≤ this while stopping [m/s³]
};

class StopProfile {
 public:
  /// At rest at 0 m.
  StopProfile() = default;

  /// Plans the stop from `start` (its jerk is ignored). Limits that are not
  /// positive and finite, or a non-finite start, give a profile with
  /// valid() == false that holds the start position: the caller checks
  /// limits at start-up, so this does not happen in the cycle.
  static StopProfile plan(const ReferenceSample& start, const StopLimits& limits) noexcept;

  bool valid() const noexcept { return valid_; }
  /// Time to rest [s].
  double duration_s() const noexcept { return duration_s_; }
  /// Where the reference comes to rest [m].
  double rest_position_m() const noexcept { return rest_position_m_; }
  /// The reference t seconds after the start of the stop; at rest from
  /// duration_s() on. Position, velocity and acceleration are continuous.
  ReferenceSample sample(double t_s) const noexcept;

 private:
  struct Segment {
    double duration_s = 0.0;
    double jerk_m_per_s3 = 0.0;
  };
  static ReferenceSample advance(const ReferenceSample& from, double jerk_m_per_s3, double t_s) noexcept;

  ReferenceSample start_{};
  std::array<Segment, 4> segments_{};
  std::size_t segment_count_ = 0;
  double duration_s_ = 0.0;
  double rest_position_m_ = 0.0;
  bool valid_ = false;
};

/// Where a stop from `start` within `limits` comes to rest [m]
/// (StopProfile::plan(start, limits).rest_position_m()).
double stopping_position_m(const ReferenceSample& start, const StopLimits& limits) noexcept;

}  // namespace clm::control
