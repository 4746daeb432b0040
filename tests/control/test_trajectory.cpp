// Jerk-limited moves and move programs: limits, continuity, exact end,
// time-optimal durations from closed-form expectations, the Fig. 8 reference,
// and allocation-free sampling.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>

#include "daemon/control/trajectory.hpp"
#include "support/allocation_counter.hpp"

using namespace clm::control;
using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

namespace {

/// Bounds on a move that hold whatever the implementation: limits, monotone
/// progress between start and end, and Taylor consistency of p, v, a with the
/// reported jerk between neighbouring grid points (a jump in p, v or a would
/// break it), with the remainder bounded by the jerk limit.
void check_move_invariants(const ThirdOrderMove& move, double start_m, double end_m, const MotionLimits& limits) {
  const double v_max = limits.velocity_m_per_s;
  const double a_max = limits.acceleration_m_per_s2;
  const double j_max = limits.jerk_m_per_s3;
  const double distance_m = std::abs(end_m - start_m);
  const double direction = end_m >= start_m ? 1.0 : -1.0;
  const double duration_s = move.duration_s();
  const double position_roundoff_m = 8.0 * std::numeric_limits<double>::epsilon() * (std::abs(start_m) + std::abs(end_m));
  const double tol_v = 1e-12 * v_max;
  const double tol_a = 1e-12 * a_max;

  // Exact end at rest, start at rest before 0.
  const ReferenceSample at_end = move.sample(duration_s);
  REQUIRE(at_end.position_m == end_m);
  REQUIRE(at_end.velocity_m_per_s == 0.0);
  REQUIRE(at_end.acceleration_m_per_s2 == 0.0);
  REQUIRE(at_end.jerk_m_per_s3 == 0.0);
  const ReferenceSample after = move.sample(duration_s + 1.0);
  REQUIRE(after.position_m == end_m);
  REQUIRE(after.velocity_m_per_s == 0.0);
  const ReferenceSample before = move.sample(-1e-3);
  REQUIRE(before.position_m == start_m);
  REQUIRE(before.velocity_m_per_s == 0.0);
  REQUIRE(before.acceleration_m_per_s2 == 0.0);
  REQUIRE(before.jerk_m_per_s3 == 0.0);
  REQUIRE(move.sample(0.0).position_m == start_m);

  constexpr int kGrid = 1000;
  const double h = duration_s / kGrid;
  for (int i = 0; i < kGrid; ++i) {
    const double t = i * h;
    const ReferenceSample s = move.sample(t);
    const ReferenceSample n = move.sample(t + h);
    INFO("t = " << t << " of " << duration_s);
    REQUIRE(std::abs(s.velocity_m_per_s) <= v_max + tol_v);
    REQUIRE(std::abs(s.acceleration_m_per_s2) <= a_max + tol_a);
    REQUIRE(std::abs(s.jerk_m_per_s3) <= j_max);
    const double progress_m = direction * (s.position_m - start_m);
    REQUIRE(progress_m >= -position_roundoff_m);
    REQUIRE(progress_m <= distance_m + position_roundoff_m);
    REQUIRE(direction * s.velocity_m_per_s >= -tol_v);
    // Taylor remainders with |jerk jump| ≤ 2 j_max inside [t, t+h].
    const double p_taylor = s.position_m + s.velocity_m_per_s * h + s.acceleration_m_per_s2 * h * h / 2 +
                            s.jerk_m_per_s3 * h * h * h / 6;
    REQUIRE(std::abs(n.position_m - p_taylor) <= j_max * h * h * h / 3 * (1 + 1e-9) + position_roundoff_m);
    const double v_taylor = s.velocity_m_per_s + s.acceleration_m_per_s2 * h + s.jerk_m_per_s3 * h * h / 2;
    REQUIRE(std::abs(n.velocity_m_per_s - v_taylor) <= j_max * h * h * (1 + 1e-9) + tol_v);
    const double a_taylor = s.acceleration_m_per_s2 + s.jerk_m_per_s3 * h;
    REQUIRE(std::abs(n.acceleration_m_per_s2 - a_taylor) <= 2 * j_max * h * (1 + 1e-9) + tol_a);
  }

  // Velocity and acceleration are the numeric derivatives of position and
  // velocity (central differences; errors bounded by j_max).
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> instant(0.0, duration_s);
  const double dh = duration_s * 1e-4;
  for (int i = 0; i < 200; ++i) {
    const double t = instant(rng);
    const ReferenceSample s = move.sample(t);
    const double dp = (move.sample(t + dh).position_m - move.sample(t - dh).position_m) / (2 * dh);
    const double dv = (move.sample(t + dh).velocity_m_per_s - move.sample(t - dh).velocity_m_per_s) / (2 * dh);
    REQUIRE(std::abs(dp - s.velocity_m_per_s) <= j_max * dh * dh / 6 * (1 + 1e-6) + position_roundoff_m / dh + tol_v);
    REQUIRE(std::abs(dv - s.acceleration_m_per_s2) <= j_max * dh / 2 * (1 + 1e-6) + 4 * tol_v / dh + tol_a);
    // The jerk is the slope of the acceleration, over a step so small that no
    // segment fits inside it (segments can be far shorter than dh); the
    // tolerance covers the rounding of t inside the segment formulas.
    const double dj = duration_s * 1e-8;
    if (move.sample(t - dj).jerk_m_per_s3 == s.jerk_m_per_s3 && move.sample(t + dj).jerk_m_per_s3 == s.jerk_m_per_s3) {
      const double da =
          (move.sample(t + dj).acceleration_m_per_s2 - move.sample(t - dj).acceleration_m_per_s2) / (2 * dj);
      REQUIRE(std::abs(da - s.jerk_m_per_s3) <= 1e-5 * j_max + 16 * std::numeric_limits<double>::epsilon() * a_max / dj);
    }
  }

  // Continuity at every jerk switch, located by bisection on the reported
  // jerk, and at the mid-time (where the profile is mirrored).
  std::vector<double> boundaries{duration_s / 2};
  for (int i = 0; i < kGrid; ++i) {
    double lo = i * h;
    double hi = lo + h;
    const double jerk_lo = move.sample(lo).jerk_m_per_s3;
    if (move.sample(hi).jerk_m_per_s3 == jerk_lo || hi >= duration_s) continue;
    for (int it = 0; it < 80; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      (move.sample(mid).jerk_m_per_s3 == jerk_lo ? lo : hi) = mid;
    }
    boundaries.push_back(0.5 * (lo + hi));
  }
  for (const double t : boundaries) {
    const double eps = duration_s * 1e-13;
    const ReferenceSample l = move.sample(t - eps);
    const ReferenceSample r = move.sample(t + eps);
    INFO("boundary t = " << t);
    REQUIRE(std::abs(l.position_m - r.position_m) <= 2 * eps * v_max + 1e-12 * distance_m + position_roundoff_m);
    REQUIRE(std::abs(l.velocity_m_per_s - r.velocity_m_per_s) <= 2 * eps * a_max + 1e-10 * v_max);
    REQUIRE(std::abs(l.acceleration_m_per_s2 - r.acceleration_m_per_s2) <= 2 * eps * j_max + 1e-10 * a_max);
  }
}

}  // namespace

TEST_CASE("random seeded moves, short and long, respect v, a, j limits and end exactly at rest", "[trajectory]") {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> start(-0.5, 0.5);
  std::uniform_real_distribution<double> log_distance(-7.0, 0.0);
  std::uniform_real_distribution<double> log_velocity(-2.0, 0.5);
  std::uniform_real_distribution<double> log_acceleration(-1.0, 2.0);
  std::uniform_real_distribution<double> log_jerk(1.0, 5.0);
  std::bernoulli_distribution negative(0.5);
  for (int trial = 0; trial < 300; ++trial) {
    const double start_m = start(rng);
    const double distance_m = std::pow(10.0, log_distance(rng));
    const double end_m = start_m + (negative(rng) ? -distance_m : distance_m);
    const MotionLimits limits{std::pow(10.0, log_velocity(rng)), std::pow(10.0, log_acceleration(rng)),
                              std::pow(10.0, log_jerk(rng))};
    INFO("trial " << trial << ": " << start_m << " -> " << end_m << " limits " << limits.velocity_m_per_s << ", "
                  << limits.acceleration_m_per_s2 << ", " << limits.jerk_m_per_s3);
    const ThirdOrderMove move = ThirdOrderMove::plan(start_m, end_m, limits);
    REQUIRE(move.duration_s() > 0.0);
    check_move_invariants(move, start_m, end_m, limits);
  }
}

TEST_CASE("a long move reaches all limits and takes D/v + v/a + a/j", "[trajectory]") {
  const MotionLimits limits{0.15, 1.0, 1000.0};
  const ThirdOrderMove move = ThirdOrderMove::plan(-0.1, 0.1, limits);
  CHECK_THAT(move.duration_s(), WithinRel(0.2 / 0.15 + 0.15 / 1.0 + 1.0 / 1000.0, 1e-13));
  CHECK_THAT(move.sample(move.duration_s() / 2).velocity_m_per_s, WithinRel(0.15, 1e-13));
  double peak_acceleration = 0.0;
  for (int i = 0; i <= 100000; ++i) {
    peak_acceleration = std::max(peak_acceleration, std::abs(move.sample(i * move.duration_s() / 100000).acceleration_m_per_s2));
  }
  CHECK_THAT(peak_acceleration, WithinRel(1.0, 1e-12));
  check_move_invariants(move, -0.1, 0.1, limits);
}

TEST_CASE("a move too short for v_max reaches a_max and peaks at the root of vp^2/a + vp*a/j = D", "[trajectory]") {
  const double distance_m = 0.01;
  const MotionLimits limits{1.0, 1.0, 1000.0};
  const ThirdOrderMove move = ThirdOrderMove::plan(0.0, distance_m, limits);
  const double a = 1.0, j = 1000.0;
  const double vp = (-a * a / j + std::sqrt(a * a * a * a / (j * j) + 4 * distance_m * a)) / 2;  // textbook root
  CHECK_THAT(move.sample(move.duration_s() / 2).velocity_m_per_s, WithinRel(vp, 1e-12));
  CHECK_THAT(move.duration_s(), WithinRel(2 * (vp / a + a / j), 1e-12));
  CHECK_THAT(move.sample(move.duration_s() / 4).acceleration_m_per_s2, WithinRel(a, 1e-12));
  check_move_invariants(move, 0.0, distance_m, limits);
}

TEST_CASE("a very short move reaches neither limit: triangular acceleration, T = 4 cbrt(D/2j)", "[trajectory]") {
  const double end_m = 0.3 - 1e-6;
  const double distance_m = 0.3 - end_m;
  const MotionLimits limits{1.0, 1.0, 1000.0};
  const ThirdOrderMove move = ThirdOrderMove::plan(0.3, end_m, limits);
  const double tj = std::cbrt(distance_m / (2 * 1000.0));
  CHECK_THAT(move.duration_s(), WithinRel(4 * tj, 1e-12));
  CHECK_THAT(move.sample(tj).acceleration_m_per_s2, WithinRel(-1000.0 * tj, 1e-9));
  CHECK(move.peak_acceleration_m_per_s2() < 1.0);
  check_move_invariants(move, 0.3, end_m, limits);
}

TEST_CASE("when v_max is hit before a_max the acceleration peaks at sqrt(v j)", "[trajectory]") {
  const MotionLimits limits{0.0005, 1.0, 1000.0};  // a²/j = 0.001 > v_max
  const ThirdOrderMove move = ThirdOrderMove::plan(0.0, 0.1, limits);
  const double tj = std::sqrt(0.0005 / 1000.0);
  CHECK_THAT(move.duration_s(), WithinRel(0.1 / 0.0005 + 2 * tj, 1e-12));
  CHECK_THAT(move.sample(tj).acceleration_m_per_s2, WithinRel(std::sqrt(0.0005 * 1000.0), 1e-9));
  check_move_invariants(move, 0.0, 0.1, limits);
}

TEST_CASE("a move in the negative direction mirrors the positive one", "[trajectory]") {
  const MotionLimits limits{0.2, 2.0, 500.0};
  // Positions exact in binary, so both distances are exactly 0.25 m.
  const ThirdOrderMove forward = ThirdOrderMove::plan(0.5, 0.75, limits);
  const ThirdOrderMove backward = ThirdOrderMove::plan(0.5, 0.25, limits);
  REQUIRE(forward.duration_s() == backward.duration_s());
  for (int i = -5; i <= 1005; ++i) {
    const double t = i * forward.duration_s() / 1000;
    const ReferenceSample f = forward.sample(t);
    const ReferenceSample b = backward.sample(t);
    REQUIRE_THAT(b.position_m - 0.5, WithinAbs(-(f.position_m - 0.5), 1e-15));
    REQUIRE(b.velocity_m_per_s == -f.velocity_m_per_s);
    REQUIRE(b.acceleration_m_per_s2 == -f.acceleration_m_per_s2);
    REQUIRE(b.jerk_m_per_s3 == -f.jerk_m_per_s3);
  }
}

TEST_CASE("a move's segments tile its duration, with the jerk and acceleration sample() gives in each",
          "[trajectory]") {
  std::mt19937_64 rng(20250301);
  std::uniform_real_distribution<double> log_distance(-7.0, 0.0);
  std::uniform_real_distribution<double> log_velocity(-6.0, 0.5);
  std::uniform_real_distribution<double> log_acceleration(-1.0, 2.0);
  std::uniform_real_distribution<double> log_jerk(1.0, 5.0);
  std::bernoulli_distribution negative(0.5);
  for (int trial = 0; trial < 300; ++trial) {
    const double distance_m = std::pow(10.0, log_distance(rng));
    const double end_m = negative(rng) ? -distance_m : distance_m;
    const MotionLimits limits{std::pow(10.0, log_velocity(rng)), std::pow(10.0, log_acceleration(rng)),
                              std::pow(10.0, log_jerk(rng))};
    INFO("trial " << trial << ": 0 -> " << end_m << " limits " << limits.velocity_m_per_s << ", "
                  << limits.acceleration_m_per_s2 << ", " << limits.jerk_m_per_s3);
    const ThirdOrderMove move = ThirdOrderMove::plan(0.0, end_m, limits);
    const double direction = end_m > 0.0 ? 1.0 : -1.0;
    REQUIRE(move.direction() == direction);
    const auto segments = move.segments();
    REQUIRE(segments.front().start_s == 0.0);
    REQUIRE(segments.back().end_s == move.duration_s());
    const double j = direction * limits.jerk_m_per_s3;
    const double expected_jerk[7] = {j, 0.0, -j, 0.0, -j, 0.0, j};
    for (std::size_t k = 0; k < segments.size(); ++k) {
      const JerkSegment& segment = segments[k];
      INFO("segment " << k + 1);
      REQUIRE(segment.end_s >= segment.start_s);
      if (k > 0) REQUIRE(segment.start_s == segments[k - 1].end_s);
      REQUIRE(segment.jerk_m_per_s3 == expected_jerk[k]);
      const double length_s = segment.end_s - segment.start_s;
      // The start acceleration is continuous with the sampled one; inside a
      // segment the sample has its jerk and the linear acceleration (up to
      // the rounding of times as large as the duration, times the jerk).
      const double tolerance = 1e-9 * limits.acceleration_m_per_s2 +
                               8.0 * std::numeric_limits<double>::epsilon() * move.duration_s() * limits.jerk_m_per_s3;
      REQUIRE_THAT(move.sample(segment.start_s).acceleration_m_per_s2,
                   WithinAbs(segment.start_acceleration_m_per_s2, tolerance));
      if (length_s > 1e-9 * move.duration_s()) {
        const double middle_s = segment.start_s + 0.5 * length_s;
        const ReferenceSample s = move.sample(middle_s);
        REQUIRE(s.jerk_m_per_s3 == segment.jerk_m_per_s3);
        REQUIRE_THAT(s.acceleration_m_per_s2,
                     WithinAbs(segment.start_acceleration_m_per_s2 + segment.jerk_m_per_s3 * 0.5 * length_s, tolerance));
      }
    }
    // The constant-acceleration and cruise segments have no jerk; the move's
    // acceleration never leaves ±peak.
    REQUIRE(std::abs(segments[1].start_acceleration_m_per_s2) == move.peak_acceleration_m_per_s2());
  }
  // A zero-length move: seven empty segments at 0.
  for (const JerkSegment& segment : ThirdOrderMove::plan(0.02, 0.02, {0.1, 1.0, 100.0}).segments()) {
    CHECK(segment.start_s == 0.0);
    CHECK(segment.end_s == 0.0);
  }
}

TEST_CASE("a zero-length move has duration 0 and stays at rest", "[trajectory]") {
  const ThirdOrderMove move = ThirdOrderMove::plan(0.02, 0.02, {0.1, 1.0, 100.0});
  REQUIRE(move.duration_s() == 0.0);
  for (const double t : {-1.0, 0.0, 1.0}) {
    const ReferenceSample s = move.sample(t);
    REQUIRE(s.position_m == 0.02);
    REQUIRE(s.velocity_m_per_s == 0.0);
    REQUIRE(s.acceleration_m_per_s2 == 0.0);
    REQUIRE(s.jerk_m_per_s3 == 0.0);
  }
}

TEST_CASE("planning rejects non-positive or non-finite limits and non-finite positions by name", "[trajectory]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  REQUIRE_THROWS_WITH(ThirdOrderMove::plan(0, 1, {0.0, 1, 1}), Contains("velocity_m_per_s") && Contains("got 0"));
  REQUIRE_THROWS_WITH(ThirdOrderMove::plan(0, 1, {1, -2, 1}), Contains("acceleration_m_per_s2") && Contains("-2"));
  REQUIRE_THROWS_WITH(ThirdOrderMove::plan(0, 1, {1, 1, nan}), Contains("jerk_m_per_s3") && Contains("nan"));
  REQUIRE_THROWS_WITH(ThirdOrderMove::plan(0, 1, {inf, 1, 1}), Contains("velocity_m_per_s") && Contains("inf"));
  REQUIRE_THROWS_WITH(ThirdOrderMove::plan(nan, 1, {1, 1, 1}), Contains("start_m"));
  REQUIRE_THROWS_WITH(ThirdOrderMove::plan(0, inf, {1, 1, 1}), Contains("end_m"));
}

TEST_CASE("a move program chains moves and dwells and matches the individual moves", "[trajectory][program]") {
  const MotionLimits fast{0.3, 3.0, 300.0};
  const MotionLimits slow{0.05, 0.5, 50.0};
  const MoveProgram program(0.01, {{0.11, fast, 0.2}, {0.11, slow, 0.1}, {-0.04, slow, 0.0}, {0.0, fast, 0.3}});
  const ThirdOrderMove m1 = ThirdOrderMove::plan(0.01, 0.11, fast);
  const ThirdOrderMove m3 = ThirdOrderMove::plan(0.11, -0.04, slow);
  const ThirdOrderMove m4 = ThirdOrderMove::plan(-0.04, 0.0, fast);
  const double t3 = m1.duration_s() + 0.2 + 0.1;  // the zero-length second step takes only its dwell
  const double t4 = t3 + m3.duration_s();
  CHECK_THAT(program.duration_s(), WithinRel(t4 + m4.duration_s() + 0.3, 1e-14));
  CHECK(program.start_m() == 0.01);
  CHECK(program.end_m() == 0.0);
  for (int i = 0; i <= 2000; ++i) {
    const double t = i * program.duration_s() / 2000;
    ReferenceSample expected;
    if (t < m1.duration_s()) {
      expected = m1.sample(t);
    } else if (t < t3) {
      expected = {0.11, 0, 0, 0};
    } else if (t < t4) {
      expected = m3.sample(t - t3);
    } else {
      expected = m4.sample(t - t4);
    }
    const ReferenceSample s = program.sample(t);
    INFO("t = " << t);
    REQUIRE_THAT(s.position_m, WithinAbs(expected.position_m, 1e-14));
    REQUIRE_THAT(s.velocity_m_per_s, WithinAbs(expected.velocity_m_per_s, 1e-12));
    REQUIRE_THAT(s.acceleration_m_per_s2, WithinAbs(expected.acceleration_m_per_s2, 1e-9));
  }
  const ReferenceSample before = program.sample(-0.5);
  CHECK(before.position_m == 0.01);
  CHECK(before.velocity_m_per_s == 0.0);
  const ReferenceSample after = program.sample(program.duration_s() + 5.0);
  CHECK(after.position_m == 0.0);
  CHECK(after.velocity_m_per_s == 0.0);
}

TEST_CASE("an empty program stays at its start, bad steps are named", "[trajectory][program]") {
  const MoveProgram empty(0.3, {});
  CHECK(empty.duration_s() == 0.0);
  CHECK(empty.sample(1.0).position_m == 0.3);
  REQUIRE_THROWS_WITH(MoveProgram(0.0, {{0.1, {1, 1, 1}, 0.0}, {0.2, {1, 1, 1}, -0.5}}),
                      Contains("step 2") && Contains("dwell_s") && Contains("-0.5"));
  REQUIRE_THROWS_WITH(MoveProgram(0.0, {{0.1, {1, 0, 1}, 0.0}}), Contains("step 1") && Contains("acceleration_m_per_s2"));
  REQUIRE_THROWS_WITH(fig8_program_at(0.0), Contains("velocity_m_per_s"));
}

TEST_CASE("the Fig. 8 reference lasts 25-27 s, stays in [-0.1, 0.1] m within its limits, dwells at the ends",
          "[trajectory][program][fig8]") {
  const MoveProgram program = fig8_program();
  // Every move of 0.2 m reaches v_max, so it takes D/v + v/a + a/j; two moves
  // and two dwells of 0.25 s per velocity.
  double expected_s = 0.0;
  for (const double v : {0.025, 0.075, 0.15}) expected_s += 2 * (0.2 / v + v / 1.0 + 1.0 / 1000.0) + 2 * 0.25;
  CHECK_THAT(program.duration_s(), WithinRel(expected_s, 1e-13));
  CHECK(program.duration_s() > 25.0);
  CHECK(program.duration_s() < 27.0);
  CHECK(program.start_m() == -0.1);
  REQUIRE(program.steps().size() == 6);

  const double dt = 1e-4;
  ReferenceSample previous = program.sample(0.0);
  double peak_velocity = 0.0;
  for (double t = dt; t <= program.duration_s() + 0.1; t += dt) {
    const ReferenceSample s = program.sample(t);
    REQUIRE(s.position_m >= -0.1 - 1e-15);
    REQUIRE(s.position_m <= 0.1 + 1e-15);
    REQUIRE(std::abs(s.velocity_m_per_s) <= 0.15 * (1 + 1e-12));
    REQUIRE(std::abs(s.acceleration_m_per_s2) <= 1.0 * (1 + 1e-12));
    REQUIRE(std::abs(s.jerk_m_per_s3) <= 1000.0);
    // Continuity across the step boundaries: increments bounded by the limits.
    REQUIRE(std::abs(s.position_m - previous.position_m) <= 0.15 * dt * (1 + 1e-9));
    REQUIRE(std::abs(s.velocity_m_per_s - previous.velocity_m_per_s) <= 1.0 * dt * (1 + 1e-9));
    REQUIRE(std::abs(s.acceleration_m_per_s2 - previous.acceleration_m_per_s2) <= 1000.0 * dt * (1 + 1e-9));
    peak_velocity = std::max(peak_velocity, std::abs(s.velocity_m_per_s));
    previous = s;
  }
  CHECK_THAT(peak_velocity, WithinRel(0.15, 1e-9));
  // In the middle of every dwell the reference rests at the target.
  for (std::size_t i = 0; i < program.steps().size(); ++i) {
    const double dwell_end_s = i + 1 < program.steps().size() ? program.step_start_s(i + 1) : program.duration_s();
    const ReferenceSample s = program.sample(dwell_end_s - 0.125);
    CHECK(s.position_m == program.steps()[i].target_m);
    CHECK(s.velocity_m_per_s == 0.0);
    CHECK(s.acceleration_m_per_s2 == 0.0);
  }
  const ReferenceSample end = program.sample(program.duration_s());
  CHECK(end.position_m == -0.1);
  CHECK(end.velocity_m_per_s == 0.0);
}

TEST_CASE("fig8_program_at is one back-and-forth at one velocity", "[trajectory][program][fig8]") {
  for (const double v : {0.025, 0.15}) {
    const MoveProgram program = fig8_program_at(v);
    CHECK_THAT(program.duration_s(), WithinRel(2 * (0.2 / v + v + 0.001) + 0.5, 1e-13));
    CHECK(program.start_m() == -0.1);
    CHECK(program.steps().size() == 2);
    CHECK(program.steps()[0].target_m == 0.1);
    CHECK(program.steps()[0].limits.velocity_m_per_s == v);
    CHECK_THAT(program.sample(program.duration_s() / 4).velocity_m_per_s, WithinRel(v, 1e-12));
  }
}

TEST_CASE("sampling moves and programs does not allocate", "[trajectory][allocation]") {
  const MoveProgram program = fig8_program();
  const ThirdOrderMove move = ThirdOrderMove::plan(0.0, 0.1, {0.1, 1.0, 1000.0});
  double sum = 0.0;
  clm::test::AllocationScope scope;
  for (int k = 0; k < 100000; ++k) {
    sum += program.sample(k * 3e-4).position_m;
    sum += move.sample(k * 1e-5).velocity_m_per_s;
  }
  REQUIRE(scope.allocations() == 0);
  REQUIRE(std::isfinite(sum));
}
