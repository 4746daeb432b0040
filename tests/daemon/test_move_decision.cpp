// servo::decide_move on its own (daemon/servo/move_decision.hpp): a pure
// function from settings, the axis's state and a command to a program or a
// refusal. The expectations are worked out here from the settings (stop
// distances in closed form, the soft limits, the limits' values), not read
// back from the code under test.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "daemon/control/stop_profile.hpp"

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

TEST_CASE("a move whose planned stop would rest past a soft limit is refused, admission plans the ordinary stop",
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

TEST_CASE("a jog heads for a following-error limit short of the soft limit, a repeat renews it", "[servo][move_decision]") {
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

namespace {

/// The brute-force reference for check_stopping: the stop from the reference
/// at every period/10, at every cycle and at every segment boundary of every
/// move, in time order.
struct DenseRest {
  std::vector<double> t_s;
  std::vector<double> rest_m;
  std::vector<bool> cycle_or_boundary;  ///< a cycle k·period or a segment boundary
};

DenseRest dense_rest(const control::MoveProgram& program, const servo::ServoSettings& s) {
  std::vector<std::pair<double, bool>> times;
  const double step_s = s.period_s / 10.0;
  for (std::int64_t k = 0; static_cast<double>(k) * step_s <= program.duration_s(); ++k) {
    times.emplace_back(static_cast<double>(k) * step_s, false);
  }
  for (std::int64_t k = 0; static_cast<double>(k) * s.period_s <= program.duration_s(); ++k) {
    times.emplace_back(static_cast<double>(k) * s.period_s, true);
  }
  times.emplace_back(program.duration_s(), true);
  for (std::size_t i = 0; i < program.moves().size(); ++i) {
    for (const control::JerkSegment& segment : program.moves()[i].segments()) {
      times.emplace_back(program.step_start_s(i) + segment.start_s, true);
      times.emplace_back(program.step_start_s(i) + segment.end_s, true);
    }
  }
  std::sort(times.begin(), times.end());
  DenseRest dense;
  for (const auto& [t_s, exact] : times) {
    dense.t_s.push_back(t_s);
    dense.rest_m.push_back(control::stopping_position_m(program.sample(t_s), s.stop_limits));
    dense.cycle_or_boundary.push_back(exact);
  }
  return dense;
}

/// The direction of motion (+1, −1) at t when the argument at find_stop_outside
/// says the rest position is monotonic there: moving, |jerk| ≤ the stop's,
/// acceleration along the motion ≥ −the stop's deceleration, and a stop that
/// need not reverse (velocity ≥ a²/(2 J) while braking); else 0. Judged from
/// the sample alone.
double monotonic_direction(const control::MoveProgram& program, double t_s, const servo::ServoSettings& s) {
  const control::ReferenceSample r = program.sample(t_s);
  if (r.velocity_m_per_s == 0.0) return 0.0;
  const double direction = r.velocity_m_per_s > 0.0 ? 1.0 : -1.0;
  const double a = direction * r.acceleration_m_per_s2;
  const double v = direction * r.velocity_m_per_s;
  const bool within = std::abs(r.jerk_m_per_s3) <= s.stop_limits.jerk_m_per_s3 &&
                      a >= -s.stop_limits.deceleration_m_per_s2 &&
                      (a >= 0.0 || v >= a * a / (2.0 * s.stop_limits.jerk_m_per_s3));
  return within ? direction : 0.0;
}

bool rests_outside(double rest_m, const servo::ServoSettings& s) {
  return rest_m < s.soft_limit_min_m - servo::kStopTolerance_m || rest_m > s.soft_limit_max_m + servo::kStopTolerance_m;
}

}  // namespace

TEST_CASE("check_stopping refuses every random program on which a dense search finds a stop resting outside",
          "[servo][move_decision][stop_check]") {
  // Random programs of 1-4 steps (some zero-length, some dwells), motion
  // limits from 0.3 to 3 times the stop's deceleration and jerk (so some
  // stretches brake harder or jerk more than the stop may, where the check
  // samples every cycle), soft limits placed around the dense search's
  // extremes so that some programs pass and some fail by as little as 3 nm.
  std::mt19937_64 rng(20250302);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto log_uniform = [&](double low, double high) { return low * std::pow(high / low, unit(rng)); };
  // How far the soft limit lies beyond the dense extreme [m]: negative is a narrow failure.
  const double margins_m[] = {-1e-5, -1e-7, -3e-9, 1e-8, 1e-6, 1e-4};
  int refused = 0;
  int admitted = 0;
  int must_refuse = 0;
  int between_cycles = 0;
  long monotonic_pairs = 0;
  for (int trial = 0; trial < 600; ++trial) {
    servo::ServoSettings s = settings();
    s.stop_limits = {log_uniform(2.0, 20.0), log_uniform(500.0, 5000.0)};
    std::vector<control::ProgramStep> steps;
    const double start_m = 0.05 * (2.0 * unit(rng) - 1.0);
    double at_m = start_m;
    const int count = 1 + static_cast<int>(unit(rng) * 4.0);
    for (int k = 0; k < count; ++k) {
      control::MotionLimits limits{log_uniform(0.02, 0.5),
                                   s.stop_limits.deceleration_m_per_s2 * log_uniform(0.3, 3.0),
                                   s.stop_limits.jerk_m_per_s3 * log_uniform(0.3, 3.0)};
      // Now and then exactly the stop's limits (the boundary of "within").
      if (unit(rng) < 0.15) limits.acceleration_m_per_s2 = s.stop_limits.deceleration_m_per_s2;
      if (unit(rng) < 0.15) limits.jerk_m_per_s3 = s.stop_limits.jerk_m_per_s3;
      const double target_m = unit(rng) < 0.1 ? at_m : std::clamp(at_m + 0.08 * (2.0 * unit(rng) - 1.0), -0.1, 0.1);
      steps.push_back({target_m, limits, unit(rng) < 0.5 ? 0.0 : 0.02 * unit(rng)});
      at_m = target_m;
    }
    const control::MoveProgram program(start_m, steps);
    const DenseRest dense = dense_rest(program, s);
    // The claim itself: between neighbouring dense times at which (and
    // half-way between which) it applies, with the same jerk, the rest
    // position does not move against the motion.
    for (std::size_t k = 1; k < dense.t_s.size(); ++k) {
      const double t0 = dense.t_s[k - 1];
      const double t1 = dense.t_s[k];
      const double middle = 0.5 * (t0 + t1);
      const double direction = monotonic_direction(program, middle, s);
      if (!(t1 > t0) || direction == 0.0 || monotonic_direction(program, t0, s) != direction ||
          monotonic_direction(program, t1, s) != direction ||
          program.sample(t0).jerk_m_per_s3 != program.sample(middle).jerk_m_per_s3 ||
          program.sample(t1).jerk_m_per_s3 != program.sample(middle).jerk_m_per_s3) {
        continue;
      }
      ++monotonic_pairs;
      if (direction * (dense.rest_m[k] - dense.rest_m[k - 1]) < -1e-12) {
        FAIL("trial " << trial << ": rest " << dense.rest_m[k - 1] << " m at t = " << t0 << " s, " << dense.rest_m[k]
                      << " m at t = " << t1 << " s, direction " << direction);
      }
    }
    // The extremes of the rest position: of all dense times, and of those the
    // check must see (the cycles, the segment boundaries, and wherever the
    // argument applies).
    const auto [lowest, highest] = std::minmax_element(dense.rest_m.begin(), dense.rest_m.end());
    double seen_min_m = 1e300;
    double seen_max_m = -1e300;
    for (std::size_t k = 0; k < dense.t_s.size(); ++k) {
      if (dense.cycle_or_boundary[k] || monotonic_direction(program, dense.t_s[k], s) != 0.0) {
        seen_min_m = std::min(seen_min_m, dense.rest_m[k]);
        seen_max_m = std::max(seen_max_m, dense.rest_m[k]);
      }
    }
    s.soft_limit_max_m = *highest + margins_m[static_cast<std::size_t>(unit(rng) * 6.0)];
    s.soft_limit_min_m = *lowest - margins_m[static_cast<std::size_t>(unit(rng) * 6.0)];
    INFO("trial " << trial << ": dense rest in [" << *lowest << ", " << *highest << "], of it seen [" << seen_min_m
                  << ", " << seen_max_m << "], soft limits [" << s.soft_limit_min_m << ", " << s.soft_limit_max_m
                  << "]");
    const servo::StopSearch search = servo::find_stop_outside(program, s);
    const std::string reason = servo::check_stopping("x", program, s);
    CHECK(reason.empty() == !search.outside);
    if (rests_outside(seen_max_m, s) || rests_outside(seen_min_m, s)) {
      ++must_refuse;
      REQUIRE(search.outside);
    } else if (rests_outside(*highest, s) || rests_outside(*lowest, s)) {
      // Only between two cycles, where no stop begins and the argument does not apply.
      ++between_cycles;
    }
    if (search.outside) {
      ++refused;
      // The reported reference is the program's at that time, and its stop really rests outside.
      const control::ReferenceSample r = program.sample(search.t_s);
      CHECK(r.position_m == search.reference.position_m);
      CHECK(r.velocity_m_per_s == search.reference.velocity_m_per_s);
      CHECK(r.acceleration_m_per_s2 == search.reference.acceleration_m_per_s2);
      CHECK(control::stopping_position_m(r, s.stop_limits) == search.rest_m);
      CHECK(rests_outside(search.rest_m, s));
      CHECK_THAT(reason, Catch::StartsWith("x: a stop at t = ") && Catch::Contains(" m/s^2) would come to rest at ") &&
                             Catch::EndsWith("] m"));
    } else {
      ++admitted;
    }
    // Well inside on both sides (1 µm or more beyond the dense extremes): admitted.
    if (s.soft_limit_max_m - *highest >= 1e-6 && *lowest - s.soft_limit_min_m >= 1e-6) {
      CHECK_FALSE(search.outside);
    }
    // Cruises cost no more than their end: at most one stop at the start,
    // for each of a move's at most 14 pieces its end and one more cycle
    // than fit in it, and every cycle of the rest of the move (its
    // acceleration and braking, 2·(2 t_j + t_a)).
    double most_stops = 1.0;
    for (const control::ThirdOrderMove& move : program.moves()) {
      most_stops += 28.0 + 2.0 * move.segments()[3].start_s / s.period_s;
    }
    CHECK(static_cast<double>(search.stops_planned) <= most_stops);
  }
  // Both outcomes occur, and many programs fail narrowly.
  UNSCOPED_INFO("refused " << refused << ", admitted " << admitted << ", must refuse " << must_refuse
                           << ", outside only between cycles " << between_cycles << ", monotonic pairs "
                           << monotonic_pairs);
  CHECK(monotonic_pairs > 100000);
  CHECK(refused > 100);
  CHECK(admitted > 100);
  CHECK(must_refuse > 100);
}

TEST_CASE("a move_to at a crawl over 0.1 m is decided with a handful of stops", "[servo][move_decision][stop_check]") {
  // 1 µm/s over 0.1 m: 10^5 s, 10^8 cycles of 1 ms. With the move's
  // acceleration and jerk within the stop's, its rest position only grows:
  // the check plans one stop at the start and one per segment end.
  const auto s = settings();
  const servo::Command crawl = move_to(0.1, {1e-6, 1.0, 1000.0});
  const auto decision = servo::decide_move(s, enabled_at(0.0), crawl);
  REQUIRE(decision.result == CommandResult::kProgramPosted);
  REQUIRE(decision.program.has_value());
  CHECK(decision.program->duration_s() > 1e5);
  const servo::StopSearch search = servo::find_stop_outside(*decision.program, s);
  CHECK_FALSE(search.outside);
  CHECK(search.stops_planned <= 8);
  // From the cruise at 1 µm/s a stop travels less than a nanometre: against
  // a soft limit at 0.05 m the program is refused, and the stop reported
  // rests outside. The first cycle past 0.05 m lies at t ≈ 5·10⁴ s; the check
  // reports the cruise's end, near 0.1 m (nothing in between is evaluated).
  auto narrow = s;
  narrow.soft_limit_max_m = 0.05;
  const servo::StopSearch outside = servo::find_stop_outside(*decision.program, narrow);
  REQUIRE(outside.outside);
  CHECK(outside.stops_planned <= 8);
  CHECK(outside.rest_m > 0.05);
  CHECK(control::stopping_position_m(decision.program->sample(outside.t_s), narrow.stop_limits) == outside.rest_m);
  CHECK(outside.reference.velocity_m_per_s == Approx(1e-6));
  CHECK_THAT(servo::check_stopping("move_to", *decision.program, narrow),
             Catch::StartsWith("move_to: a stop at t = ") && Catch::EndsWith("outside the soft limits [-0.1, 0.05] m"));
}
