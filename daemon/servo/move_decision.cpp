#include "daemon/servo/move_decision.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <tuple>
#include <vector>

namespace clm::servo {
namespace {

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

MoveDecision refuse(CommandResult result, std::string detail = "") { return {result, std::move(detail), std::nullopt}; }

bool inside_soft_limits(const ServoSettings& settings, double position_m) {
  return position_m >= settings.soft_limit_min_m && position_m <= settings.soft_limit_max_m;
}

/// "" when `target_m` lies inside the soft limits, else the refusal naming it and them.
std::string check_target(const std::string& what, double target_m, const ServoSettings& settings) {
  if (inside_soft_limits(settings, target_m)) return "";
  return what + ": target_m " + number(target_m) + " m lies outside the soft limits [" +
         number(settings.soft_limit_min_m) + ", " + number(settings.soft_limit_max_m) + "] m";
}

/// `program` admitted when every stop from it rests inside (unless `check_stop` is false).
MoveDecision admit(const ServoSettings& settings, const std::string& what, control::MoveProgram program,
                   CommandResult accepted, bool check_stop = true) {
  if (check_stop) {
    if (auto reason = check_stopping(what, program, settings); !reason.empty()) {
      return refuse(CommandResult::kRejectedStopOutside, reason);
    }
  }
  return {accepted, "", std::move(program)};
}

MoveDecision decide_move_to(const ServoSettings& settings, const AxisSnapshot& axis, const Command& command) {
  // Restricted mode (after kPositionOutOfRange): only a slow move back inside.
  const std::string what = axis.restricted ? "move_to (restricted mode)" : "move_to";
  if (auto reason = check_target(what, command.target_m, settings); !reason.empty()) {
    return refuse(CommandResult::kRejectedOutsideSoftLimits, reason);
  }
  control::MotionLimits max = settings.motion_limits;
  if (axis.restricted) max.velocity_m_per_s *= settings.recovery_velocity_fraction;
  if (auto reason = check_motion_limits(what, command.limits, max); !reason.empty()) {
    return refuse(CommandResult::kRejectedMotionLimit, reason);
  }
  control::MoveProgram move(axis.hold_position_m, {{command.target_m, command.limits, 0.0}});
  // In restricted mode the move starts outside; it only goes back inside.
  return admit(settings, "move_to", std::move(move), CommandResult::kProgramPosted, !axis.restricted);
}

MoveDecision decide_program(const ServoSettings& settings, const AxisSnapshot& axis, const ProgramSteps& program) {
  if (axis.restricted) return refuse(CommandResult::kRejectedRestricted);
  if (program.steps.empty()) return refuse(CommandResult::kRejectedInvalid, "run_program: the program has no steps");
  for (std::size_t i = 0; i < program.steps.size(); ++i) {
    const control::ProgramStep& step = program.steps[i];
    const std::string what = "run_program: step " + std::to_string(i + 1);
    if (auto reason = check_target(what, step.target_m, settings); !reason.empty()) {
      return refuse(CommandResult::kRejectedOutsideSoftLimits, reason);
    }
    if (auto reason = check_motion_limits(what, step.limits, settings.motion_limits); !reason.empty()) {
      return refuse(CommandResult::kRejectedMotionLimit, reason);
    }
  }
  return admit(settings, "run_program", program_from_hold(program, axis.hold_position_m),
               CommandResult::kProgramPosted);
}

MoveDecision decide_jog(const ServoSettings& settings, const AxisSnapshot& axis, const Command& command) {
  const control::MotionLimits& l = command.limits;
  if (axis.jog_running) {
    // A repeat keeps the jog going; anything else waits for it to end.
    const bool same = command.jog_velocity_m_per_s == axis.jog_velocity_m_per_s &&
                      l.acceleration_m_per_s2 == axis.jog_limits.acceleration_m_per_s2 &&
                      l.jerk_m_per_s3 == axis.jog_limits.jerk_m_per_s3;
    return same ? MoveDecision{CommandResult::kJogging, "", std::nullopt} : refuse(CommandResult::kRejectedOtherJog);
  }
  if (!axis.at_rest) return refuse(CommandResult::kRejectedBusy);
  // Towards the soft limit, a following-error limit short of it so that the
  // axis, within that of its reference, stays inside.
  const bool up = command.jog_velocity_m_per_s > 0.0;
  const double band_m = settings.following_error_limit_m;
  const double target_m = up ? settings.soft_limit_max_m - band_m : settings.soft_limit_min_m + band_m;
  if (up ? target_m <= axis.hold_position_m : target_m >= axis.hold_position_m) {
    return refuse(CommandResult::kRejectedAtSoftLimit);
  }
  control::MoveProgram move(axis.hold_position_m, {{target_m, l, 0.0}});
  return admit(settings, "jog", std::move(move), CommandResult::kJogStarted);
}

}  // namespace

std::string check_motion_limits(const std::string& what, const control::MotionLimits& limits,
                                const control::MotionLimits& max) {
  for (const auto& [key, value, limit, unit] :
       {std::tuple{"velocity_m_per_s", limits.velocity_m_per_s, max.velocity_m_per_s, "m/s"},
        std::tuple{"acceleration_m_per_s2", limits.acceleration_m_per_s2, max.acceleration_m_per_s2, "m/s^2"},
        std::tuple{"jerk_m_per_s3", limits.jerk_m_per_s3, max.jerk_m_per_s3, "m/s^3"}}) {
    if (!(value <= limit)) {
      return what + ": " + key + " " + number(value) + " " + unit + " exceeds the limit " + number(limit) + " " + unit +
             " (motion." + key + ")";
    }
  }
  return "";
}

// Which references check_stopping plans a stop from, and why that is enough.
//
// rest(t) = stopping_position_m(program.sample(t), stop_limits), with J the
// stop's jerk and D its deceleration. The program is a sequence of
// rest-to-rest ThirdOrderMoves, each seven segments of constant jerk, and
// dwells at rest. Take a forward move (direction +1, so velocity ≥ 0) and a
// stretch of it on which throughout
//   (1) the program's jerk magnitude is ≤ J,
//   (2) its acceleration is ≥ −D, and
//   (3) the stop need not reverse: velocity ≥ a²/(2J) wherever a < 0.
// Then rest(t) does not decrease over the stretch:
//  - Following the program from t for dt and then stopping is itself a stop
//    from the state at t that keeps jerk within ±J, acceleration ≥ −D and
//    velocity ≥ 0 (by (3) the stop from t + dt does not reverse), and it
//    rests at rest(t + dt).
//  - Of all such stops the stop profile (jerk −J until the acceleration
//    reaches −a_p, hold, +J to rest) rests nearest: until it meets the curve
//    v = a²/(2J) its acceleration max(a₀ − J·s, −a_p) is the lowest any of
//    them can have, and from there it follows that curve down to rest, below
//    which none can go without reversing. Its velocity is the lowest at every
//    instant, so its distance is the shortest. By (3) it is one of them.
//  - Hence rest(t) ≤ rest(t + dt).
// A backward move is the mirror image: rest(t) does not increase. Either way
// the extremes of rest(t) on the stretch lie at its two ends, and checking
// both ends against both soft limits checks every instant in between.
//
// (3) holds wherever a ≥ 0, and on the braking half of a move whose jerk is
// ≤ J (its last segment, at jerk ≤ J, still has to take the acceleration to
// zero). It fails late in the constant-deceleration segment of a move whose
// jerk exceeds J: there the stop overshoots backwards, and rest(t) peaks where
// velocity = a²/(2J), inside the segment (found by the randomized test in
// test_move_decision.cpp against a dense search).
//
// So each segment of each move is split where, inside it, the acceleration
// along the direction crosses −D (the −j segment of the braking half and the
// final +j one, when the move brakes harder than the stop) and, on the
// constant-deceleration segment, where the velocity falls to a²/(2J) (when
// the move's jerk exceeds J). Each condition is monotonic in time within a
// segment, so each piece meets (1)-(3) throughout or nowhere but at its ends;
// it is judged at its middle. A piece that meets them is checked at its end
// (its start is the previous piece's end, or the move's start at rest); any
// other at every cycle k · period_s inside it and at its end, as before this
// argument was used. Accelerating segments meet them whenever the move's
// jerk is ≤ J, the constant-acceleration and cruise segments always; the
// pieces that do not last at most a_max/j or v/a_max each, so a move at a
// crawl over a long distance costs a handful of stops instead of one per
// cycle. Dwells are at rest at the move's end, checked as the last piece's
// end; a program with no move is checked at t = 0. Every cycle's reference
// is either evaluated or lies in a piece whose ends bound its rest, so this
// refuses whatever the check at every cycle refused (and may refuse a move
// whose stop from a piece's end between two cycles rests outside).
StopSearch find_stop_outside(const control::MoveProgram& program, const ServoSettings& settings) {
  StopSearch search;
  // True (and `search` filled in) when the stop from the reference at t rests outside.
  const auto rests_outside = [&](double t_s) {
    const control::ReferenceSample s = program.sample(t_s);
    const double rest_m = control::stopping_position_m(s, settings.stop_limits);
    ++search.stops_planned;
    if (rest_m >= settings.soft_limit_min_m - kStopTolerance_m &&
        rest_m <= settings.soft_limit_max_m + kStopTolerance_m) {
      return false;
    }
    search = {true, t_s, s, rest_m, search.stops_planned};
    return true;
  };
  // Program times t_begin < t ≤ t_end [s] to evaluate: every cycle strictly inside when
  // the rest position there need not be monotonic, then the end.
  const auto piece_rests_outside = [&](double t_begin_s, double t_end_s, bool monotonic) {
    if (!monotonic) {
      for (auto k = static_cast<std::int64_t>(std::floor(t_begin_s / settings.period_s)) + 1;; ++k) {
        const double t = static_cast<double>(k) * settings.period_s;
        if (t >= t_end_s) break;
        if (t > t_begin_s && rests_outside(t)) return true;
      }
    }
    return rests_outside(t_end_s);
  };

  if (rests_outside(0.0)) return search;
  const double stop_jerk = settings.stop_limits.jerk_m_per_s3;
  const double stop_deceleration = settings.stop_limits.deceleration_m_per_s2;
  const std::vector<control::ThirdOrderMove>& moves = program.moves();
  for (std::size_t i = 0; i < moves.size(); ++i) {
    const control::ThirdOrderMove& move = moves[i];
    const double step_start_s = program.step_start_s(i);
    const double direction = move.direction();
    for (const control::JerkSegment& segment : move.segments()) {
      if (!(segment.end_s > segment.start_s)) continue;
      // Along the direction of motion the acceleration is a0 + j·τ over the segment.
      const double a0 = direction * segment.start_acceleration_m_per_s2;
      const double j = direction * segment.jerk_m_per_s3;
      // Where, inside the segment, a condition of the argument starts or stops holding
      // (at most one per segment): the acceleration crosses −D on a segment with jerk; on
      // the constant-deceleration segment, the velocity falls below a²/(2J) (only when the
      // move's jerk exceeds J).
      double split_s = segment.end_s;
      if (j != 0.0) {
        split_s = segment.start_s + (-stop_deceleration - a0) / j;
      } else if (a0 < 0.0) {
        const double v0 = direction * move.sample(segment.start_s).velocity_m_per_s;
        split_s = segment.start_s + (v0 - a0 * a0 / (2.0 * stop_jerk)) / -a0;
      }
      const bool split = split_s > segment.start_s && split_s < segment.end_s;
      // Each piece: monotonic when the conditions hold at its middle.
      double piece_start_s = segment.start_s;
      for (const double piece_end_s : {split ? split_s : segment.end_s, segment.end_s}) {
        if (!(piece_end_s > piece_start_s)) continue;
        const double middle_s = 0.5 * (piece_start_s + piece_end_s);
        const double a = a0 + j * (middle_s - segment.start_s);
        const double v = direction * move.sample(middle_s).velocity_m_per_s;
        const bool no_reversal =
            a >= 0.0 || move.limits().jerk_m_per_s3 <= stop_jerk || v >= a * a / (2.0 * stop_jerk);
        const bool monotonic =
            std::abs(segment.jerk_m_per_s3) <= stop_jerk && a >= -stop_deceleration && no_reversal;
        if (piece_rests_outside(step_start_s + piece_start_s, step_start_s + piece_end_s, monotonic)) return search;
        piece_start_s = piece_end_s;
      }
    }
  }
  return search;
}

std::string check_stopping(const std::string& what, const control::MoveProgram& program,
                           const ServoSettings& settings) {
  const StopSearch search = find_stop_outside(program, settings);
  if (!search.outside) return "";
  const control::ReferenceSample& s = search.reference;
  return what + ": a stop at t = " + number(search.t_s) + " s (r = " + number(s.position_m) + " m, v = " +
         number(s.velocity_m_per_s) + " m/s, a = " + number(s.acceleration_m_per_s2) +
         " m/s^2) would come to rest at " + number(search.rest_m) + " m, outside the soft limits [" +
         number(settings.soft_limit_min_m) + ", " + number(settings.soft_limit_max_m) + "] m";
}

control::MoveProgram program_from_hold(const ProgramSteps& program, double hold_m) {
  std::vector<control::ProgramStep> steps;
  if (!program.steps.empty() && std::abs(program.start_m - hold_m) > 1e-9) {
    steps.push_back({program.start_m, program.steps.front().limits, 0.0});
  }
  steps.insert(steps.end(), program.steps.begin(), program.steps.end());
  return control::MoveProgram(hold_m, std::move(steps));
}

MoveDecision decide_move(const ServoSettings& settings, const AxisSnapshot& axis, const Command& command,
                         const ProgramSteps& program) {
  const CommandKind kind = command.kind;
  if (kind != CommandKind::kMoveTo && kind != CommandKind::kRunProgram && kind != CommandKind::kJog) {
    return refuse(CommandResult::kRejectedInvalid, std::string(route(kind).name) + " is not a move");
  }
  if (const CommandResult legal = check_legal(kind, axis.state, axis.at_rest); legal != CommandResult::kAccepted) {
    return refuse(legal);
  }
  if (kind == CommandKind::kJog && axis.restricted) return refuse(CommandResult::kRejectedRestricted);
  if (axis.parameter_change_pending) return refuse(CommandResult::kRejectedParameterPending);
  try {
    switch (kind) {
      case CommandKind::kMoveTo: return decide_move_to(settings, axis, command);
      case CommandKind::kRunProgram: return decide_program(settings, axis, program);
      default: {
        if (auto reason = check_motion_limits("jog", command.limits, settings.motion_limits); !reason.empty()) {
          return refuse(CommandResult::kRejectedMotionLimit, reason);
        }
        return decide_jog(settings, axis, command);
      }
    }
  } catch (const std::invalid_argument& e) {
    // A limit or target the trajectory cannot plan (not positive, not finite).
    return refuse(CommandResult::kRejectedInvalid, std::string(route(kind).name) + ": " + e.what());
  }
}

}  // namespace clm::servo
