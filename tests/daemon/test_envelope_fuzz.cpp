// A property test of the safe envelope (docs/servod.md, "The safe envelope";
// slow tier): random sequences of run-time `set`s, each value inside its
// own documented range (half of them log-uniform over the range, the way a
// tired operator mistypes by orders of magnitude, half the present value
// times 1/4 … 4, the way one tunes), a random move after each accepted set, on the
// virtual clock with the in-process simulated motor. Whatever was accepted,
// the translator never touches an end stop (the simulator's truth: its
// collision count, and the true position inside the end stops every cycle).
// Faults may latch on the way (a push of the settings is not forbidden to
// fault); they are cleared and the walk goes on. Fixed seeds.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>

#include "daemon/servod/axis_wiring.hpp"
#include "daemon/servod/parameters.hpp"
#include "drivers/sim/motor.hpp"
#include "daemon_support.hpp"

using namespace clm;
using servo::CommandKind;
using servo::ServoState;

namespace {

constexpr int kSeeds = 10;
constexpr int kStepsPerSeed = 1000;  // 10 000 set-and-move sequences in all
constexpr std::int64_t kMaxMoveCycles = 600;  // a slower move is stopped after 0.6 s: a stop from speed too

struct Walk {
  explicit Walk(std::uint64_t seed) : wired(test::virtual_config()), daemon(wired.daemon), random(seed) {
    daemon.run_cycles(10);
    enable();
  }

  sim::SimulatedMotor& motor() { return *wired.simulated_motor(); }

  void enable() {
    if (daemon.cycle().status().state == ServoState::kFault) test::command(daemon, CommandKind::kClearFault, 2);
    test::command(daemon, CommandKind::kEnable, 20);
  }

  /// One cycle, and the truth inside the end stops.
  void cycle() {
    daemon.run_cycles(1);
    const double y = motor().truth().position_m;
    if (!(y > end_min_m && y < end_max_m)) {
      FAIL("the translator reached an end stop: y = " << y << " m after " << accepted << " accepted sets");
    }
  }

  /// A `set` of a random parameter to a value of its range (see above): true when accepted.
  bool random_set() {
    const auto parameters = servod::runtime_parameters();
    const servod::RuntimeParameter& p = parameters[std::uniform_int_distribution<std::size_t>(0, parameters.size() - 1)(random)];
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
    const auto reply = daemon.submit(set);
    if (!reply.accepted()) return false;
    cycle();
    cycle();
    for (const auto& answer : daemon.take_replies()) {
      if (!answer.accepted()) return false;
    }
    ++accepted;
    return true;
  }

  /// A move to a random target inside the soft limits at the limits now in force.
  void random_move() {
    if (daemon.cycle().status().state != ServoState::kEnabled) enable();
    if (daemon.cycle().status().state != ServoState::kEnabled) return;
    const servo::ServoSettings& fixed = daemon.config().servo;  // the soft limits are fixed at start-up
    servo::Command move;
    move.kind = CommandKind::kMoveTo;
    move.target_m = std::uniform_real_distribution<double>(fixed.soft_limit_min_m, fixed.soft_limit_max_m)(random);
    move.limits = daemon.runtime_values().tuning.motion_limits;
    if (!daemon.submit(move).accepted()) return;
    std::int64_t k = 0;
    for (; k < kMaxMoveCycles; ++k) {
      cycle();
      if (daemon.cycle().mailbox().at_rest() && k > 2) break;
    }
    if (k == kMaxMoveCycles) {
      // A move at a crawl (a velocity limit set to micrometres a second): stopped.
      test::command(daemon, CommandKind::kStop, 1);
      for (k = 0; k < kMaxMoveCycles && !daemon.cycle().mailbox().at_rest(); ++k) cycle();
    }
    for (int settle = 0; settle < 30; ++settle) cycle();  // settle, and a fault's reaction to its end
    (void)daemon.take_replies();
  }

  servod::WiredAxis wired;
  servod::ServoDaemon& daemon;
  std::mt19937_64 random;
  double end_min_m = -0.13;  // the simulated motor's hard stops (config/motor-sim.yaml)
  double end_max_m = 0.13;
  int accepted = 0;
};

}  // namespace

TEST_CASE("no sequence of accepted sets lets a move reach an end stop (10 000 sequences, fixed seeds)",
          "[daemon][envelope][slow]") {
  int accepted_sets = 0;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    INFO("seed " << seed);
    Walk walk(static_cast<std::uint64_t>(seed));
    walk.end_min_m = walk.motor().parameters().mechanics.end_stop_min_m;
    walk.end_max_m = walk.motor().parameters().mechanics.end_stop_max_m;
    for (int step = 0; step < kStepsPerSeed; ++step) {
      INFO("step " << step);
      if (walk.random_set()) walk.random_move();
    }
    CHECK(walk.motor().truth().end_stop_collisions == 0);
    accepted_sets += walk.accepted;
  }
  // The walk must have changed something for the property to mean anything.
  INFO("accepted sets: " << accepted_sets);
  std::printf("envelope walk: %d of %d in-range sets accepted, a move after each, no end stop reached\n", accepted_sets,
              kSeeds * kStepsPerSeed);
  CHECK(accepted_sets > kSeeds * kStepsPerSeed / 20);
}
