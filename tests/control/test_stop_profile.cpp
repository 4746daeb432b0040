// The jerk-limited stop (daemon/control/stop_profile.hpp) against closed-form
// stopping distances, the deceleration half of a planned move, and invariants
// over random starting states: at rest at the end, limits held, continuous.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "daemon/control/stop_profile.hpp"
#include "support/allocation_counter.hpp"

using namespace clm::control;

namespace {

ReferenceSample state(double position_m, double velocity_m_per_s, double acceleration_m_per_s2) {
  ReferenceSample s;
  s.position_m = position_m;
  s.velocity_m_per_s = velocity_m_per_s;
  s.acceleration_m_per_s2 = acceleration_m_per_s2;
  return s;
}

/// Samples the profile densely and checks the limits, continuity and the rest.
void require_invariants(const StopProfile& stop, const StopLimits& limits) {
  REQUIRE(stop.valid());
  const double dt = stop.duration_s() / 2000.0 + 1e-9;
  ReferenceSample previous = stop.sample(0.0);
  for (double t = dt; t <= stop.duration_s() + 2 * dt; t += dt) {
    const ReferenceSample s = stop.sample(t);
    INFO("t = " << t << " of " << stop.duration_s());
    REQUIRE(std::fabs(s.acceleration_m_per_s2) <= limits.deceleration_m_per_s2 * (1 + 1e-9) + 1e-12);
    REQUIRE(std::fabs(s.jerk_m_per_s3) <= limits.jerk_m_per_s3 * (1 + 1e-12));
    // Continuity: a step of dt changes a by at most j·dt, v by at most a_max·dt.
    REQUIRE(std::fabs(s.acceleration_m_per_s2 - previous.acceleration_m_per_s2) <= limits.jerk_m_per_s3 * dt * 1.001);
    REQUIRE(std::fabs(s.velocity_m_per_s - previous.velocity_m_per_s) <=
            limits.deceleration_m_per_s2 * dt * 1.001 + 1e-12);
    previous = s;
  }
  const ReferenceSample end = stop.sample(stop.duration_s() + 1.0);
  CHECK(end.velocity_m_per_s == 0.0);
  CHECK(end.acceleration_m_per_s2 == 0.0);
  CHECK(end.position_m == stop.rest_position_m());
  // The integrated end state is at rest too, not only the held sample.
  const ReferenceSample last = stop.sample(stop.duration_s() * (1 - 1e-12));
  CHECK(std::fabs(last.velocity_m_per_s) < 1e-9);
  CHECK(std::fabs(last.acceleration_m_per_s2) < 1e-6);
  CHECK(std::fabs(last.position_m - stop.rest_position_m()) < 1e-9);
}

}  // namespace

TEST_CASE("a stop from rest is at rest at once", "[stop]") {
  const auto stop = StopProfile::plan(state(0.05, 0, 0), {2.0, 100.0});
  CHECK(stop.duration_s() == 0.0);
  CHECK(stop.rest_position_m() == 0.05);
}

TEST_CASE("from constant velocity the stopping distance is v²/(2a) + v·a/(2j) (trapezoid) or the triangle's",
          "[stop]") {
  const StopLimits limits{2.0, 100.0};
  // Trapezoid: v large enough to reach a_max (v > a²/j = 0.04 m/s).
  for (double v : {0.1, 0.5, -0.8}) {
    const auto stop = StopProfile::plan(state(0.0, v, 0.0), limits);
    const double a = limits.deceleration_m_per_s2, j = limits.jerk_m_per_s3, speed = std::fabs(v);
    CHECK(stop.rest_position_m() == Approx(std::copysign(speed * speed / (2 * a) + speed * a / (2 * j), v)).epsilon(1e-12));
    CHECK(stop.duration_s() == Approx(speed / a + a / j).epsilon(1e-12));
    require_invariants(stop, limits);
  }
  // Triangle: a_p = √(v·j), duration 2·√(v/j), distance v·√(v/j).
  const double v = 0.01;
  const auto stop = StopProfile::plan(state(0.0, v, 0.0), limits);
  CHECK(stop.rest_position_m() == Approx(v * std::sqrt(v / 100.0)).epsilon(1e-12));
  CHECK(stop.duration_s() == Approx(2 * std::sqrt(v / 100.0)).epsilon(1e-12));
  require_invariants(stop, limits);
}

TEST_CASE("a stop where a move starts to decelerate ends at the move's target", "[stop]") {
  const MotionLimits limits{0.3, 2.0, 100.0};
  const auto move = ThirdOrderMove::plan(-0.1, 0.1, limits);
  // The move cruises at v_max from the end of its acceleration phase until its
  // deceleration (mirror of the first half) starts.
  const double accel_phase_s = limits.velocity_m_per_s / limits.acceleration_m_per_s2 +
                               limits.acceleration_m_per_s2 / limits.jerk_m_per_s3;
  const double decel_start_s = move.duration_s() - accel_phase_s;
  const ReferenceSample at = move.sample(decel_start_s);
  REQUIRE(at.velocity_m_per_s == Approx(0.3));
  const auto stop = StopProfile::plan(at, {limits.acceleration_m_per_s2, limits.jerk_m_per_s3});
  CHECK(stop.rest_position_m() == Approx(0.1).margin(1e-12));
  CHECK(stop.duration_s() == Approx(accel_phase_s).epsilon(1e-9));
}

TEST_CASE("random states come to rest within the limits, from any acceleration, even beyond the limit", "[stop]") {
  std::mt19937_64 engine(14);
  std::uniform_real_distribution<double> velocity(-1.0, 1.0), acceleration(-3.0, 3.0);
  const StopLimits limits{2.0, 50.0};
  for (int trial = 0; trial < 300; ++trial) {
    const ReferenceSample start = state(0.0, velocity(engine), acceleration(engine));
    INFO("v0 = " << start.velocity_m_per_s << ", a0 = " << start.acceleration_m_per_s2);
    const auto stop = StopProfile::plan(start, limits);
    if (std::fabs(start.acceleration_m_per_s2) <= limits.deceleration_m_per_s2) {
      require_invariants(stop, limits);
    } else {
      // The first segment brings |a| back to the limit; from then on the limits hold.
      const ReferenceSample end = stop.sample(stop.duration_s() + 1.0);
      CHECK(end.velocity_m_per_s == 0.0);
      const ReferenceSample last = stop.sample(stop.duration_s() * (1 - 1e-12));
      CHECK(std::fabs(last.velocity_m_per_s) < 1e-9);
    }
  }
}

TEST_CASE("invalid limits hold the start position, planning and sampling do not allocate", "[stop]") {
  const auto held = StopProfile::plan(state(0.02, 0.5, 0.0), {0.0, 100.0});
  CHECK_FALSE(held.valid());
  CHECK(held.sample(1.0).position_m == 0.02);
  CHECK(held.sample(1.0).velocity_m_per_s == 0.0);

  clm::test::AllocationScope counter;
  double sum = 0.0;
  for (int i = 0; i < 10000; ++i) {
    const auto stop = StopProfile::plan(state(0.0, 0.001 * i, 0.1), {2.0, 100.0});
    sum += stop.sample(0.01).position_m + stopping_position_m(state(0, 0.1, 0), {2.0, 100.0});
  }
  CHECK(counter.allocations() == 0);
  CHECK(std::isfinite(sum));
}
