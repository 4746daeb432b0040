// servo::decide_move on its own (daemon/servo/move_decision.hpp): a pure
// function from settings, the axis's state and a command to a program or a
// refusal. The expectations are worked out here from the settings (stop
// distances in closed form, the soft limits, the limits' values), not read
// back from the code under test.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "daemon/servo/move_decision.hpp"

using namespace clm;
using servo::CommandKind;
using servo::CommandResult;
using servo::ServoState;

namespace {

/// Soft limits ±0.1 m, moves up to 0.5 m/s, 10 m/s², 2000 m/s³; stop within
/// 10 m/s², 2000 m/s³ and quick stop within 20 m/s², 4000 m/s³.
servo::ServoSettings settings() {
  servo::ServoSettings s;
  s.period_s = 1e-3;
  s.soft_limit_min_m = -0.1;
  s.soft_limit_max_m = 0.1;
  s.following_error_limit_m = 1e-3;
  s.motion_limits = {0.5, 10.0, 2000.0};
  s.stop_limits = {10.0, 2000.0};
  s.quick_stop_limits = {20.0, 4000.0};
  s.recovery_velocity_fraction = 0.1;
  return s;
}

servo::AxisSnapshot enabled_at(double hold_m) {
  servo::AxisSnapshot axis;
  axis.state = ServoState::kEnabled;
  axis.at_rest = true;
  axis.hold_position_m = hold_m;
  return axis;
}

servo::Command move_to(double target_m, control::MotionLimits limits) {
  servo::Command command;
  command.kind = CommandKind::kMoveTo;
  command.target_m = target_m;
  command.limits = limits;
  return command;
}

servo::Command jog(double velocity_m_per_s, control::MotionLimits limits = {0.1, 1.0, 1000.0}) {
  servo::Command command;
  command.kind = CommandKind::kJog;
  command.jog_velocity_m_per_s = velocity_m_per_s;
  command.limits = limits;
  command.limits.velocity_m_per_s = std::abs(velocity_m_per_s);
  return command;
}

}  // namespace

TEST_CASE("a valid move_to gives a program from the hold position whose end is the target", "[servo][move_decision]") {
  const auto decision = servo::decide_move(settings(), enabled_at(-0.02), move_to(0.05, {0.2, 2.0, 500.0}));
  REQUIRE(decision.result == CommandResult::kProgramPosted);
  REQUIRE(decision.program.has_value());
  CHECK(decision.detail.empty());
  CHECK(decision.program->start_m() == -0.02);
  CHECK(decision.program->end_m() == 0.05);
  // 0.07 m at 0.2 m/s takes at least 0.35 s; the reference ends at rest on the target.
  CHECK(decision.program->duration_s() > 0.35);
  const control::ReferenceSample end = decision.program->sample(decision.program->duration_s());
  CHECK(end.position_m == Approx(0.05).margin(1e-12));
  CHECK(end.velocity_m_per_s == Approx(0.0).margin(1e-12));
}

TEST_CASE("limits above the motion limits are refused naming the value and the limit", "[servo][move_decision]") {
  const auto axis = enabled_at(0.0);
  auto decision = servo::decide_move(settings(), axis, move_to(0.05, {0.6, 2.0, 500.0}));
  CHECK(decision.result == CommandResult::kRejectedMotionLimit);
  CHECK_FALSE(decision.program.has_value());
  CHECK(decision.detail == "move_to: velocity_m_per_s 0.6 m/s exceeds the limit 0.5 m/s (motion.velocity_m_per_s)");
  decision = servo::decide_move(settings(), axis, move_to(0.05, {0.5, 10.0, 2500.0}));
  CHECK(decision.detail == "move_to: jerk_m_per_s3 2500 m/s^3 exceeds the limit 2000 m/s^3 (motion.jerk_m_per_s3)");
  decision = servo::decide_move(settings(), axis, jog(-0.1, {0.1, 12.0, 1000.0}));
  CHECK(decision.result == CommandResult::kRejectedMotionLimit);
  CHECK(decision.detail ==
        "jog: acceleration_m_per_s2 12 m/s^2 exceeds the limit 10 m/s^2 (motion.acceleration_m_per_s2)");
  // Exactly at the limits is allowed.
  CHECK(servo::decide_move(settings(), axis, move_to(0.05, {0.5, 10.0, 2000.0})).result ==
        CommandResult::kProgramPosted);
}

TEST_CASE("a move whose planned stop would rest past a soft limit is refused; admission plans the ordinary stop",
          "[servo][move_decision]") {
  // A move to the soft limit at 10 m/s²: with a stop as hard as the move's
  // braking, every stop rests at or before the target: accepted.
  const servo::Command to_limit = move_to(0.1, {0.5, 10.0, 2000.0});
  auto s = settings();
  CHECK(servo::decide_move(s, enabled_at(-0.1), to_limit).result == CommandResult::kProgramPosted);
  // A softer stop (5 m/s²): from cruise at 0.5 m/s it needs
  // v²/(2a) + v·a/(2j) = 0.025 + 0.000625 m, more than the move's own braking
  // (0.0125 + 0.00125 m): near the end of the cruise it would rest beyond 0.1 m.
  s.stop_limits = {5.0, 2000.0};
  auto decision = servo::decide_move(s, enabled_at(-0.1), to_limit);
  CHECK(decision.result == CommandResult::kRejectedStopOutside);
  CHECK_FALSE(decision.program.has_value());
  CHECK_THAT(decision.detail, Catch::StartsWith("move_to: a stop at t = ") &&
                                  Catch::EndsWith("outside the soft limits [-0.1, 0.1] m"));
  // The quick stop does not admit a move: still refused with a hard quick stop.
  s.quick_stop_limits = {1000.0, 1e6};
  CHECK(servo::decide_move(s, enabled_at(-0.1), to_limit).result == CommandResult::kRejectedStopOutside);
  // The same target braked at 1 m/s², softer than the stop: a stop from any
  // sample rests before the move's own end, the soft limit: accepted.
  CHECK(servo::decide_move(s, enabled_at(-0.1), move_to(0.1, {0.1, 1.0, 1000.0})).result ==
        CommandResult::kProgramPosted);
}

TEST_CASE("a target outside the soft limits, and moves in the wrong state, are refused", "[servo][move_decision]") {
  auto axis = enabled_at(0.0);
  const auto outside = servo::decide_move(settings(), axis, move_to(0.1 + 1e-6, {0.1, 1.0, 1000.0}));
  CHECK(outside.result == CommandResult::kRejectedOutsideSoftLimits);
  CHECK(outside.detail == "move_to: target_m 0.100001 m lies outside the soft limits [-0.1, 0.1] m");
  axis.state = ServoState::kFault;
  CHECK(servo::decide_move(settings(), axis, move_to(0.05, {0.1, 1.0, 1000.0})).result ==
        CommandResult::kRejectedFault);
  axis.state = ServoState::kDisabled;
  CHECK(servo::decide_move(settings(), axis, jog(0.1)).result == CommandResult::kRejectedDisabled);
  axis = enabled_at(0.0);
  axis.at_rest = false;
  CHECK(servo::decide_move(settings(), axis, move_to(0.05, {0.1, 1.0, 1000.0})).result ==
        CommandResult::kRejectedBusy);
  CHECK(servo::decide_move(settings(), axis, jog(0.1)).result == CommandResult::kRejectedBusy);
  axis = enabled_at(0.0);
  axis.parameter_change_pending = true;
  CHECK(servo::decide_move(settings(), axis, move_to(0.05, {0.1, 1.0, 1000.0})).result ==
        CommandResult::kRejectedParameterPending);
  // Not a move at all.
  servo::Command enable;
  enable.kind = CommandKind::kEnable;
  CHECK(servo::decide_move(settings(), enabled_at(0.0), enable).result == CommandResult::kRejectedInvalid);
  // A limit the trajectory cannot plan is refused, not thrown.
  const auto zero = servo::decide_move(settings(), enabled_at(0.0), move_to(0.05, {0.1, 0.0, 1000.0}));
  CHECK(zero.result == CommandResult::kRejectedInvalid);
  CHECK_THAT(zero.detail, Catch::StartsWith("move_to: "));
}

TEST_CASE("restricted mode admits only a slow move_to back inside", "[servo][move_decision]") {
  auto axis = enabled_at(0.105);  // 5 mm beyond the upper soft limit
  axis.restricted = true;
  // 0.1 × 0.5 m/s = 0.05 m/s at most.
  auto decision = servo::decide_move(settings(), axis, move_to(0.09, {0.06, 1.0, 1000.0}));
  CHECK(decision.result == CommandResult::kRejectedMotionLimit);
  CHECK(decision.detail ==
        "move_to (restricted mode): velocity_m_per_s 0.06 m/s exceeds the limit 0.05 m/s (motion.velocity_m_per_s)");
  decision = servo::decide_move(settings(), axis, move_to(0.09, {0.05, 1.0, 1000.0}));
  REQUIRE(decision.result == CommandResult::kProgramPosted);
  CHECK(decision.program->start_m() == 0.105);
  CHECK(decision.program->end_m() == 0.09);
  decision = servo::decide_move(settings(), axis, move_to(0.11, {0.05, 1.0, 1000.0}));
  CHECK(decision.result == CommandResult::kRejectedOutsideSoftLimits);
  CHECK(decision.detail ==
        "move_to (restricted mode): target_m 0.11 m lies outside the soft limits [-0.1, 0.1] m");
  CHECK(servo::decide_move(settings(), axis, jog(-0.01)).result == CommandResult::kRejectedRestricted);
  servo::Command run;
  run.kind = CommandKind::kRunProgram;
  const std::vector<control::ProgramStep> steps{{0.0, {0.05, 1.0, 1000.0}, 0.0}};
  CHECK(servo::decide_move(settings(), axis, run, {0.105, steps}).result == CommandResult::kRejectedRestricted);
}

TEST_CASE("a jog heads for a following-error limit short of the soft limit; a repeat renews it", "[servo][move_decision]") {
  auto decision = servo::decide_move(settings(), enabled_at(0.0), jog(0.1));
  REQUIRE(decision.result == CommandResult::kJogStarted);
  CHECK(decision.program->start_m() == 0.0);
  CHECK(decision.program->end_m() == 0.1 - 1e-3);
  decision = servo::decide_move(settings(), enabled_at(0.0), jog(-0.1));
  REQUIRE(decision.result == CommandResult::kJogStarted);
  CHECK(decision.program->end_m() == -0.1 + 1e-3);
  // Already there.
  CHECK(servo::decide_move(settings(), enabled_at(0.1 - 1e-3), jog(0.1)).result == CommandResult::kRejectedAtSoftLimit);
  // While one runs: the same jog renews it (no new program), another is refused.
  auto running = enabled_at(0.02);
  running.at_rest = false;
  running.jog_running = true;
  running.jog_velocity_m_per_s = 0.1;
  running.jog_limits = jog(0.1).limits;
  decision = servo::decide_move(settings(), running, jog(0.1));
  CHECK(decision.result == CommandResult::kJogging);
  CHECK_FALSE(decision.program.has_value());
  CHECK(servo::decide_move(settings(), running, jog(0.2)).result == CommandResult::kRejectedOtherJog);
}

TEST_CASE("run_program checks every step and first moves to the file's start", "[servo][move_decision]") {
  servo::Command run;
  run.kind = CommandKind::kRunProgram;
  const control::MotionLimits slow{0.1, 1.0, 1000.0};
  std::vector<control::ProgramStep> steps{{0.05, slow, 0.0}, {-0.05, slow, 0.1}};
  auto decision = servo::decide_move(settings(), enabled_at(0.0), run, {0.02, steps});
  REQUIRE(decision.result == CommandResult::kProgramPosted);
  CHECK(decision.program->start_m() == 0.0);
  REQUIRE(decision.program->steps().size() == 3);
  CHECK(decision.program->steps()[0].target_m == 0.02);  // the move to the file's start
  CHECK(decision.program->end_m() == -0.05);
  // Already at the start: no extra move.
  decision = servo::decide_move(settings(), enabled_at(0.02), run, {0.02, steps});
  REQUIRE(decision.result == CommandResult::kProgramPosted);
  CHECK(decision.program->steps().size() == 2);

  steps[1].target_m = 0.2;
  decision = servo::decide_move(settings(), enabled_at(0.0), run, {0.02, steps});
  CHECK(decision.result == CommandResult::kRejectedOutsideSoftLimits);
  CHECK(decision.detail == "run_program: step 2: target_m 0.2 m lies outside the soft limits [-0.1, 0.1] m");
  steps[1].target_m = -0.05;
  steps[1].limits.jerk_m_per_s3 = 3000.0;
  decision = servo::decide_move(settings(), enabled_at(0.0), run, {0.02, steps});
  CHECK(decision.result == CommandResult::kRejectedMotionLimit);
  CHECK(decision.detail == "run_program: step 2: jerk_m_per_s3 3000 m/s^3 exceeds the limit 2000 m/s^3 (motion.jerk_m_per_s3)");
  CHECK(servo::decide_move(settings(), enabled_at(0.0), run, {0.0, {}}).result == CommandResult::kRejectedInvalid);
}

TEST_CASE("check_stopping finds the first cycle whose stop rests outside, with the rest position",
          "[servo][move_decision]") {
  // From rest at 0.099 m a stop rests where it is: inside, at every sample.
  auto s = settings();
  const control::MoveProgram at_rest(0.099, {});
  CHECK(servo::check_stopping("x", at_rest, s).empty());
  // A program that starts outside: the stop at t = 0 rests there.
  const control::MoveProgram outside(0.2, {});
  CHECK(servo::check_stopping("x", outside, s) ==
        "x: a stop at t = 0 s (r = 0.2 m, v = 0 m/s, a = 0 m/s^2) would come to rest at 0.2 m, outside the soft "
        "limits [-0.1, 0.1] m");
}
