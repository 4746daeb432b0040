#pragma once
// Reference trajectories for the position loop: the jerk-limited ("third
// order") point-to-point move and programs of moves and dwells, among them the
// reference of the paper's Fig. 8 on which the commutation data sets and the
// Table 2 results were recorded.
//
// Planning may throw std::invalid_argument (offline, at start-up); sampling is
// noexcept and does not allocate, so the cycle can call it.

#include <array>
#include <cstddef>
#include <vector>

namespace clm::control {

/// Bounds of a move, magnitudes (the same in both directions). All must be
/// positive and finite.
struct MotionLimits {
  double velocity_m_per_s;      ///< |v| ≤ v_max [m/s]
  double acceleration_m_per_s2;  ///< |a| ≤ a_max [m/s²]
  double jerk_m_per_s3;          ///< |j| ≤ j_max [m/s³]
};

/// The reference and its first three time derivatives at one instant.
struct ReferenceSample {
  double position_m = 0;             ///< r [m]
  double velocity_m_per_s = 0;       ///< ṙ [m/s]
  double acceleration_m_per_s2 = 0;  ///< r̈ [m/s²]
  double jerk_m_per_s3 = 0;          ///< r⃛ [m/s³]
};

/// One constant-jerk segment of a ThirdOrderMove, in time since the move's
/// start. Over it the acceleration is linear in time: from
/// `start_acceleration_m_per_s2` at `start_s` by `jerk_m_per_s3` per second.
struct JerkSegment {
  double start_s = 0;                     ///< [s]
  double end_s = 0;                       ///< [s], ≥ start_s (equal for a segment the move drops)
  double jerk_m_per_s3 = 0;               ///< signed: (+j, 0, −j, 0, −j, 0, +j)·direction [m/s³]
  double start_acceleration_m_per_s2 = 0;  ///< signed, from the plan (not sampled) [m/s²]
};

/// Time-optimal, jerk-limited move from rest to rest: seven segments of
/// constant jerk (+j, 0, −j, 0, −j, 0, +j)·direction. Moves too short to reach
/// v_max drop the constant-velocity segment; moves too short to reach a_max
/// also drop the constant-acceleration segments (triangular acceleration).
/// The profile is point-symmetric about its mid-time: the second half is the
/// first half mirrored, so the end is reached exactly.
class ThirdOrderMove {
 public:
  /// A zero-length move at 0 m (duration 0).
  ThirdOrderMove() = default;

  /// Plans the move. Throws std::invalid_argument naming the value if a
  /// position is not finite or a limit is not positive and finite. A zero-length
  /// move is valid and has duration 0.
  static ThirdOrderMove plan(double start_m, double end_m, const MotionLimits& limits);

  /// Total time from start to end [s].
  double duration_s() const { return duration_s_; }
  double start_m() const { return start_m_; }
  double end_m() const { return end_m_; }
  const MotionLimits& limits() const { return limits_; }
  /// Largest |velocity| the move reaches [m/s] (≤ v_max).
  double peak_velocity_m_per_s() const { return peak_velocity_m_per_s_; }
  /// Largest |acceleration| the move reaches [m/s²] (≤ a_max).
  double peak_acceleration_m_per_s2() const { return peak_acceleration_m_per_s2_; }

  /// +1 for a move towards larger positions, −1 towards smaller, 0 for a
  /// zero-length move.
  double direction() const { return direction_; }
  /// The seven constant-jerk segments in order, (+j, 0, −j, 0, −j, 0, +j)·
  /// direction, the second half the mirror image of the first. A segment the
  /// move drops (no constant acceleration, no cruise; all for a zero-length
  /// move) has zero length. The boundaries are the times sample() switches
  /// formula at: 0, t_j, t_j + t_a, 2 t_j + t_a, then mirrored from the end.
  std::array<JerkSegment, 7> segments() const noexcept;

  /// The reference at time t [s] since the start of the move, in closed form
  /// (cubic in t per segment). Before 0: start at rest; from duration_s() on:
  /// end at rest (position exactly end_m()). Position, velocity and
  /// acceleration are continuous; at a boundary between segments the jerk of
  /// either neighbour may be returned.
  ReferenceSample sample(double t_s) const noexcept;

 private:
  /// Distance [m], speed, acceleration and jerk along the direction of motion
  /// at time t in the first half, 0 ≤ t ≤ duration/2.
  ReferenceSample first_half(double t_s) const noexcept;

  double start_m_ = 0.0;
  double end_m_ = 0.0;
  MotionLimits limits_{0.0, 0.0, 0.0};
  double direction_ = 0.0;                   ///< +1, −1, or 0 for a zero-length move
  double jerk_time_s_ = 0.0;                 ///< duration of each constant-jerk segment [s]
  double constant_acceleration_time_s_ = 0.0;  ///< duration of each constant-acceleration segment [s]
  double duration_s_ = 0.0;
  double peak_velocity_m_per_s_ = 0.0;
  double peak_acceleration_m_per_s2_ = 0.0;
};

/// One step of a program: a move to `target_m` within `limits`, then a dwell
/// at rest for `dwell_s` [s] (≥ 0).
struct ProgramStep {
  double target_m;
  MotionLimits limits;
  double dwell_s;
};

/// A sequence of moves and dwells starting at rest at `start_m`. The moves are
/// planned at construction; sample() does not allocate and finds the step by
/// binary search over the precomputed step start times.
class MoveProgram {
 public:
  /// Plans every step. Throws std::invalid_argument naming the step (1-based)
  /// and the bad value if a target, limit or dwell is invalid. An empty
  /// program is valid: it stays at `start_m`.
  MoveProgram(double start_m, std::vector<ProgramStep> steps);

  /// Sum of all move durations and dwells [s].
  double duration_s() const { return duration_s_; }
  double start_m() const { return start_m_; }
  /// Position at the end of the program [m].
  double end_m() const { return moves_.empty() ? start_m_ : moves_.back().end_m(); }
  const std::vector<ProgramStep>& steps() const { return steps_; }
  /// The planned move of each step, in step order.
  const std::vector<ThirdOrderMove>& moves() const { return moves_; }
  /// Time [s] at which step `index` (0-based) begins its move.
  double step_start_s(std::size_t index) const { return step_start_s_.at(index); }

  /// The reference at time t [s] since the program start. Before 0: start at
  /// rest; after duration_s(): the last target at rest.
  ReferenceSample sample(double t_s) const noexcept;

 private:
  double start_m_;
  std::vector<ProgramStep> steps_;
  std::vector<ThirdOrderMove> moves_;
  std::vector<double> step_start_s_;
  double duration_s_ = 0.0;
};

/// Limits of the paper's Fig. 8 reference at a maximum velocity [m/s]:
/// a_max = 1 m/s², j_max = 1000 m/s³.
MotionLimits fig8_limits(double velocity_m_per_s);

/// The reference of the paper's Fig. 8: from rest at −0.1 m, for v_max = 0.025,
/// 0.075 and 0.15 m/s in turn: move to +0.1 m, dwell 0.25 s, move to −0.1 m,
/// dwell 0.25 s (a_max = 1 m/s², j_max = 1000 m/s³). Duration ≈ 26.0 s.
MoveProgram fig8_program();

/// One back-and-forth of the Fig. 8 reference at a single maximum velocity
/// [m/s] (the slow and fast references of Figs. 10/11). Throws
/// std::invalid_argument if the velocity is not positive and finite.
MoveProgram fig8_program_at(double velocity_m_per_s);

}  // namespace clm::control
