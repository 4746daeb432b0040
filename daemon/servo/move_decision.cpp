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

std::string check_stopping(const std::string& what, const control::MoveProgram& program,
                           const ServoSettings& settings) {
  const double duration_s = program.duration_s();
  const auto samples = static_cast<std::int64_t>(std::ceil(duration_s / settings.period_s));
  for (std::int64_t k = 0; k <= samples; ++k) {
    const double t = std::min(static_cast<double>(k) * settings.period_s, duration_s);
    const control::ReferenceSample s = program.sample(t);
    const double rest_m = control::stopping_position_m(s, settings.stop_limits);
    if (rest_m < settings.soft_limit_min_m - kStopTolerance_m || rest_m > settings.soft_limit_max_m + kStopTolerance_m) {
      return what + ": a stop at t = " + number(t) + " s (r = " + number(s.position_m) + " m, v = " +
             number(s.velocity_m_per_s) + " m/s, a = " + number(s.acceleration_m_per_s2) +
             " m/s^2) would come to rest at " + number(rest_m) + " m, outside the soft limits [" +
             number(settings.soft_limit_min_m) + ", " + number(settings.soft_limit_max_m) + "] m";
    }
  }
  return "";
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
