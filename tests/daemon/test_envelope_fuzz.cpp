// A property test of the safe envelope (docs/servod.md, "The safe envelope";
// slow tier): 10 000 random sequences of run-time `set`s, each value inside
// its own documented range (half of them log-uniform over the range, the way
// a tired operator mistypes by orders of magnitude, half the present value
// times 1/4 … 4, the way one tunes), with moves after each accepted set, on
// the virtual clock with the in-process simulated motor. A sequence is sets
// until one or two are accepted, each followed by its moves, so every
// sequence ends with moves on the settings it left. Whatever was accepted,
// the translator never touches an end stop (the simulator's truth: its count
// of end-stop contacts, and its position inside the end stops).
//
// The moves are the dangerous ones: mostly an approach to a soft limit at the
// highest velocity, acceleration and jerk the settings allow, from a run-up
// point just far enough away to reach that velocity (v²/a + v·a/j, at least
// 20 ms of travel), so a move is short and still arrives at full speed; some
// go anywhere within 0.3 s of travel. No move is planned longer than
// 0.25 s at its limits (settings with a tiny acceleration or jerk have
// slow moves only; this keeps the daemon's stop check of each move, one
// sample per cycle of it, from costing seconds). A move the daemon refuses (a stop from
// it would rest outside the soft limits) is tried again slower. Faults may
// latch on the way (a push of the settings is not forbidden to fault); they
// are cleared and the walk goes on. Fixed seeds.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>

#include "daemon/control/stop_profile.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/servod/axis_wiring.hpp"
#include "daemon/servod/parameters.hpp"
#include "drivers/sim/motor.hpp"
#include "daemon_support.hpp"

using namespace clm;
using servo::CommandKind;
using servo::CommandResult;

namespace {

constexpr int kSeeds = 10;
constexpr int kSequencesPerSeed = 1000;          // 10 000 sequences in all
constexpr int kMaxSetAttempts = 2000;            // per accepted set; about one in eight is accepted
constexpr std::int64_t kMaxMoveCycles = 1000;    // a move still running after 1 s is stopped
constexpr std::int64_t kStopMarginCycles = 2000;  // beyond a stop's own profile: the loop settling at rest
constexpr double kMinTravelTime_s = 0.02;        // a run-up gives at least this much travel at full speed
constexpr double kAnywhereTravelTime_s = 0.3;    // an "anywhere" move goes at most this far at full speed
constexpr double kMoveTime_s = 0.25;             // no move is planned longer than this at its limits

struct Walk {
  explicit Walk(std::uint64_t seed) : wired(test::virtual_config()), daemon(wired.daemon), random(seed) {
    daemon.run_cycles(10);
    recover();
    const servo::ServoSettings& fixed = daemon.config().servo;  // the soft limits are fixed at start-up
    soft_min_m = fixed.soft_limit_min_m;
    soft_max_m = fixed.soft_limit_max_m;
    end_min_m = motor().parameters().mechanics.end_stop_min_m;
    end_max_m = motor().parameters().mechanics.end_stop_max_m;
  }

  sim::SimulatedMotor& motor() { return *wired.simulated_motor(); }

  /// Clears a fault and enables; each answered by the daemon (refused when
  /// there is no fault, or the axis is enabled already).
  void recover() {
    test::command(daemon, CommandKind::kClearFault, 2);
    test::command(daemon, CommandKind::kEnable, 5);
    (void)daemon.take_replies();
  }

  /// Every run-time parameter as the daemon uses it now.
  std::string settings() {
    const servod::RuntimeValues values = daemon.runtime_values();
    std::string text;
    for (const servod::RuntimeParameter& p : servod::runtime_parameters()) {
      text += "\n  " + servod::describe_parameter(p, servod::parameter_value(values, p));
    }
    return text;
  }

  /// The simulator's truth: no end-stop contact so far, the translator inside
  /// the end stops. Names the seed, the sequence, its sets, the settings and the move.
  void require_no_end_stop(const char* when) {
    const auto& truth = motor().truth();
    if (truth.end_stop_collisions == contacts_reported && truth.position_m > end_min_m && truth.position_m < end_max_m) {
      return;
    }
    contacts_reported = truth.end_stop_collisions;
    ++failures;
    FAIL_CHECK("seed " << seed_label << ", sequence " << sequence << " (" << when << "): the translator reached an end stop"
                 << " (contacts " << truth.end_stop_collisions << ", y = " << truth.position_m << " m)\n"
                 << "sets of this sequence:" << sets_log << "\nlast move: " << move_log << "\nsettings in force:"
                 << settings());
  }

  /// A `set` of a random parameter to a value of its range (see above): true when accepted.
  bool random_set() {
    const auto parameters = servod::runtime_parameters();
    const servod::RuntimeParameter& p =
        parameters[std::uniform_int_distribution<std::size_t>(0, parameters.size() - 1)(random)];
    if (p.max <= p.min) return false;  // fixed at start-up
    const double low = std::max(p.min, 1e-9);
    const double present = servod::parameter_value(daemon.runtime_values(), p);
    const auto log_uniform = [&](double a, double b) {
      return std::exp(std::uniform_real_distribution<double>(std::log(a), std::log(b))(random));
    };
    const double value = std::bernoulli_distribution(0.5)(random) || !(present > 0.0)
                             ? log_uniform(low, p.max)
                             : std::clamp(present * log_uniform(0.25, 4.0), p.min, p.max);
    servo::Command set;
    set.kind = CommandKind::kSetParameter;
    set.parameter.assign(p.key);
    set.value = value;
    const servod::CommandReply reply = daemon.submit(set);
    if (!reply.accepted()) {
      last_set_refusal = reply.text();
      return false;
    }
    daemon.run_cycles(2);
    for (const auto& answer : daemon.take_replies()) {
      if (!answer.accepted()) {
        last_set_refusal = answer.text();
        return false;
      }
    }
    sets_log += "\n  set " + servod::describe_parameter(p, value);
    ++accepted_sets;
    return true;
  }

  /// The farthest a move within `limits` goes in kMoveTime_s: a cruise at
  /// v, a triangular acceleration at a, or one at j (no further than half
  /// the soft limits' span).
  double longest_move_m(const control::MotionLimits& limits) const {
    const double T = kMoveTime_s;
    return std::min({limits.velocity_m_per_s * T, limits.acceleration_m_per_s2 * T * T / 4.0,
                     limits.jerk_m_per_s3 * T * T * T / 32.0, (soft_max_m - soft_min_m) / 2});
  }

  /// A move to `target_m` (brought within longest_move_m of the axis) within `limits`, run until the axis is idle (at most
  /// kMaxMoveCycles, then stopped) and settled; false when the daemon refused
  /// it (the reason in `refusal`).
  bool move_to(double target_m, const control::MotionLimits& limits, CommandResult& refusal, bool bounded = true) {
    // No farther than a move of kMoveTime_s at these limits goes (see above).
    const double y = motor().truth().position_m;
    const double longest_m = longest_move_m(limits);
    if (bounded) {
      target_m = std::clamp(target_m, y - longest_m, y + longest_m);
      // The planned move itself (control::ThirdOrderMove, as the daemon plans
      // it) within kMoveTime_s: ramps at a small acceleration or jerk add to
      // the cruise; halve the distance until it fits.
      for (int k = 0; k < 60 && control::ThirdOrderMove::plan(y, target_m, limits).duration_s() > kMoveTime_s; ++k) {
        target_m = y + 0.5 * (target_m - y);
      }
    }
    servo::Command move;
    move.kind = CommandKind::kMoveTo;
    move.target_m = target_m;
    move.limits = limits;
    std::ostringstream text;
    text << "move-to " << target_m << " m from y = " << y << " m at v " << limits.velocity_m_per_s
         << " m/s, a " << limits.acceleration_m_per_s2 << " m/s^2, j " << limits.jerk_m_per_s3 << " m/s^3";
    move_log = text.str();
    auto reply = daemon.submit(move);
    if (reply.result == CommandResult::kRejectedFault || reply.result == CommandResult::kRejectedDisabled) {
      recover();
      reply = daemon.submit(move);
    }
    if (!reply.accepted()) {
      refusal = reply.result;
      return false;
    }
    if (daemon.run_until_idle(kMaxMoveCycles) == kMaxMoveCycles) {
      // Longer than its design (kMoveTime_s: a move of that duration at the
      // limits; its jerk-limited ramps add at most about as much again):
      // stopped. A stop's own limits may make it take long (a stop jerk of
      // 1e-5 m/s³ takes minutes to end an acceleration): it is let run, and
      // quick-stopped if it runs on.
      // Each stop is given its own profile's time from the worst state a
      // move within these limits can be in (full speed, full acceleration
      // onwards), plus a margin: accepted limits may make it minutes long (a
      // stop deceleration of 1e-6 m/s² takes 324 s from 0.32 mm/s).
      const servo::Tuning& tuning = daemon.runtime_values().tuning;
      const auto stop_cycles = [&](const control::StopLimits& stop) {
        const control::ReferenceSample worst{0.0, limits.velocity_m_per_s, limits.acceleration_m_per_s2, 0.0};
        const double seconds = control::StopProfile::plan(worst, stop).duration_s();
        return static_cast<std::int64_t>(std::ceil(seconds * daemon.config().loop.rate_hz)) + kStopMarginCycles;
      };
      const std::int64_t stop_limit = stop_cycles(tuning.stop_limits);
      test::command(daemon, CommandKind::kStop, 1);
      if (daemon.run_until_idle(stop_limit) == stop_limit) {
        const std::int64_t quick_limit = stop_cycles(tuning.quick_stop_limits);
        test::command(daemon, CommandKind::kQuickStop, 1);
        if (daemon.run_until_idle(quick_limit) == quick_limit) {
          FAIL("seed " << seed_label << ", sequence " << sequence << ": a stop and a quick stop did not end within "
                       << stop_limit << " and " << quick_limit << " cycles (their profiles' time from full speed "
                       << "and acceleration, and " << kStopMarginCycles << " more); last move: " << move_log
                       << "\nsettings in force:" << settings());
        }
      }
    }
    daemon.run_cycles(5);  // the walk's next cycles go on watching: a late contact is still counted
    (void)daemon.take_replies();
    ++moves;
    require_no_end_stop("after a move");
    return true;
  }

  /// The dangerous moves on the settings in force (see above); true when at
  /// least one ran. A refused approach is tried again farther inside the soft
  /// limit and slower, in turns; at last a small slow move towards the middle.
  bool moves_on_settings() {
    const control::MotionLimits in_force = daemon.runtime_values().tuning.motion_limits;
    bool moved = false;
    for (int attempt = 0; attempt < 12; ++attempt) {
      if (const double y = motor().truth().position_m; y < soft_min_m || y > soft_max_m) {
        // Outside the soft limits (fault 202, then restricted mode): back
        // inside at the restricted velocity, the whole way (at most
        // motion.recovery_margin_m and a millimetre).
        control::MotionLimits back = in_force;
        back.velocity_m_per_s *= daemon.config().servo.recovery_velocity_fraction * 0.99;
        CommandResult ignored = CommandResult::kAccepted;
        moved = move_to(std::clamp(y, soft_min_m + 1e-3, soft_max_m - 1e-3), back, ignored, false) || moved;
        continue;
      }
      control::MotionLimits limits = in_force;
      limits.velocity_m_per_s *= std::pow(0.5, (attempt + 1) / 2);
      const double inset_m = 1e-3 * std::pow(2.0, attempt / 2);
      const double v = limits.velocity_m_per_s;
      const double a = limits.acceleration_m_per_s2;
      const double j = limits.jerk_m_per_s3;
      // Run-up: accelerate to v and brake from it, jerk-limited; but no
      // longer than a move of kMoveTime_s at the limits can go (a tiny
      // acceleration or jerk never gets far: its moves are slow anyway), so
      // that a move stays short in simulated time.
      const double longest_m = longest_move_m(limits);
      const double run_up_m = std::min(std::max(v * v / a + v * a / j, v * kMinTravelTime_s) *
                                           std::uniform_real_distribution<double>(1.0, 1.5)(random),
                                       longest_m);
      const double y = motor().truth().position_m;
      CommandResult refusal = CommandResult::kAccepted;
      if (std::bernoulli_distribution(0.15)(random)) {
        // Anywhere within kAnywhereTravelTime_s of travel.
        const double reach_m = std::min(v * kAnywhereTravelTime_s + run_up_m, longest_m);
        const double target_m = std::clamp(y + std::uniform_real_distribution<double>(-reach_m, reach_m)(random),
                                           soft_min_m + inset_m, soft_max_m - inset_m);
        if (move_to(target_m, limits, refusal)) return true;
      } else {
        // Approach a soft limit (mostly the one of the last approach) from a run-up point.
        if (std::bernoulli_distribution(0.1)(random)) toward_max = !toward_max;
        const double inset_fraction = std::uniform_real_distribution<double>(0.0, 1.0)(random);
        const auto run_up_point = [&] {
          const double limit_m = toward_max ? soft_max_m : soft_min_m;
          const double inward = toward_max ? -1.0 : 1.0;
          return std::pair{limit_m + inward * inset_m * inset_fraction,
                           limit_m + inward * (inset_m * inset_fraction + run_up_m)};
        };
        auto [target_m, start_m] = run_up_point();
        if (std::abs(y - start_m) > longest_m) {  // too far to get there in one short move: the nearer limit
          toward_max = y > 0.5 * (soft_min_m + soft_max_m);
          std::tie(target_m, start_m) = run_up_point();
        }
        if (std::abs(y - start_m) > longest_m) {
          // Still too far for these limits: a short move towards it.
          if (move_to(y + std::clamp(start_m - y, -longest_m, longest_m), limits, refusal)) return true;
          continue;
        }
        const bool run_up_ran = std::abs(y - start_m) < 1e-4 || move_to(start_m, limits, refusal);
        moved = moved || run_up_ran;
        if (run_up_ran && move_to(target_m, limits, refusal)) return true;
      }
      (void)refusal;  // refused as too fast to stop inside the soft limits, or busy: slower, farther inside
    }
    if (!moved) {
      control::MotionLimits crawl = in_force;
      crawl.velocity_m_per_s = std::min(crawl.velocity_m_per_s, 1e-5);
      const double y = motor().truth().position_m;
      CommandResult refusal = CommandResult::kAccepted;
      moved = move_to(y + (y > 0.0 ? -1e-5 : 1e-5), crawl, refusal);
    }
    return moved;
  }

  servod::WiredAxis wired;
  servod::ServoDaemon& daemon;
  std::mt19937_64 random;
  double soft_min_m = 0.0, soft_max_m = 0.0;
  double end_min_m = -0.13, end_max_m = 0.13;  // replaced by the simulated motor's hard stops
  bool toward_max = true;
  int seed_label = 0;
  int sequence = 0;
  std::string sets_log, move_log, last_set_refusal;
  int accepted_sets = 0;
  int moves = 0;
  int contacts_reported = 0;  ///< end-stop contacts already reported (each is reported once, and the walk goes on)
  int failures = 0;
};

}  // namespace

TEST_CASE("no sequence of accepted sets lets a move reach an end stop (10 000 sequences, fixed seeds)",
          "[daemon][envelope][slow]") {
  std::int64_t cycles = 0;
  int accepted_sets = 0, moves = 0, set_attempts = 0, sequences_moved = 0, immovable = 0, failures = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    Walk walk(static_cast<std::uint64_t>(seed));
    walk.seed_label = seed;
    for (int sequence = 0; sequence < kSequencesPerSeed; ++sequence) {
      walk.sequence = sequence;
      walk.sets_log.clear();
      // One or two accepted sets, each followed by its moves; settings on
      // which the daemon admits no move at all (a stop jerk of 1e-5 m/s³
      // makes every stop end beyond the soft limits) are set on from until
      // one moves, so the sequence ends with a move on the settings it left.
      const int wanted = std::bernoulli_distribution(0.25)(walk.random) ? 2 : 1;
      bool moved = false;
      for (int set = 0; set < wanted || !moved; ++set) {
        REQUIRE(set < 1000);
        if (set >= wanted) ++immovable;
        int attempts = 0;
        while (!walk.random_set()) {
          ++attempts;
          INFO("seed " << seed << ", sequence " << sequence << ": the last set refused: " << walk.last_set_refusal
                       << "\nlast move: " << walk.move_log << "\nsettings in force:" << walk.settings());
          REQUIRE(attempts < kMaxSetAttempts);
        }
        set_attempts += attempts + 1;
        moved = walk.moves_on_settings();
      }
      ++sequences_moved;
    }
    walk.daemon.run_cycles(200);  // the last move's aftermath
    walk.require_no_end_stop("at the end of the seed");
    accepted_sets += walk.accepted_sets;
    cycles += walk.daemon.cycles_done();
    failures += walk.failures;
    moves += walk.moves;
  }
  std::printf("envelope walk: %d sequences, each ending with a move on its settings; %d of %d in-range sets "
              "accepted (%d of them after settings that admitted no move), %d moves, %lld cycles; %d reached an end stop\n",
              sequences_moved, accepted_sets, set_attempts, immovable, moves, static_cast<long long>(cycles), failures);
  CHECK(sequences_moved == kSeeds * kSequencesPerSeed);
  CHECK(moves >= kSeeds * kSequencesPerSeed);
}
