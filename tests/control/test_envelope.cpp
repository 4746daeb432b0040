// The safe envelope (daemon/control/envelope.hpp): the shipped default lies
// inside it; each relation refuses a setting just past its bound, computed
// here from the relation, and accepts one just inside; the combination found
// driving the axis into its end stop is refused.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "daemon/control/envelope.hpp"

using namespace clm::control;

namespace {

/// config/servod.yaml on config/motor-sim.yaml.
Machine default_machine() { return Machine{15.0, -0.12, 0.12}; }

EnvelopeSettings default_settings() {
  EnvelopeSettings s;
  s.period_s = 1e-3;
  s.soft_limit_min_m = -0.11;
  s.soft_limit_max_m = 0.11;
  s.following_error_limit_m = 0.002;
  s.force_limit_N = 600.0;
  s.saturation_time_limit_s = 0.05;
  s.motion_limits = {0.5, 10.0, 2000.0};
  s.stop_limits = {10.0, 2000.0};
  s.quick_stop_limits = {20.0, 4000.0};
  s.pid = tune_pid(15.0, 40.0);
  return s;
}

/// Refused, naming `key`.
void check_refused(const EnvelopeSettings& s, const std::string& key) {
  const std::string reason = check_envelope(default_machine(), s);
  INFO("reason: " << reason);
  CHECK(reason.find(key) != std::string::npos);
}

void check_accepted(const EnvelopeSettings& s) {
  const std::string reason = check_envelope(default_machine(), s);
  INFO("reason: " << reason);
  CHECK(reason.empty());
}

constexpr double kJustPast = 1.001;
constexpr double kJustInside = 0.999;

}  // namespace

TEST_CASE("the default configuration lies inside the envelope", "[envelope]") { check_accepted(default_settings()); }

TEST_CASE("the combination that hit the end stop is refused, and each of its settings on its own too", "[envelope]") {
  EnvelopeSettings s = default_settings();
  s.feedforward.mass_kg = 10000.0;
  s.following_error_limit_m = 1.0;
  s.saturation_time_limit_s = 10.0;
  CHECK_FALSE(check_envelope(default_machine(), s).empty());
  EnvelopeSettings one = default_settings();
  one.feedforward.mass_kg = 10000.0;
  check_refused(one, "control.feedforward.mass_kg");
  one = default_settings();
  one.following_error_limit_m = 1.0;
  check_refused(one, "control.following_error_limit_m");
  one = default_settings();
  one.saturation_time_limit_s = 10.0;
  check_refused(one, "control.saturation_time_limit_s");
  one = default_settings();
  one.motion_limits.velocity_m_per_s = 100.0;
  check_refused(one, "motion.velocity_m_per_s");
  one = default_settings();
  one.motion_limits.acceleration_m_per_s2 = 1e4;
  check_refused(one, "motion.acceleration_m_per_s2");
}

TEST_CASE("each relation's bound, from its formula: just past is refused, just inside accepted", "[envelope]") {
  const double m = 15.0, force_N = 600.0;
  SECTION("1. move acceleration: m a <= 0.5 F") {
    EnvelopeSettings s = default_settings();
    s.motion_limits.acceleration_m_per_s2 = kJustPast * kMoveForceShare * force_N / m;
    check_refused(s, "motion.acceleration_m_per_s2");
    s.motion_limits.acceleration_m_per_s2 = kJustInside * kMoveForceShare * force_N / m;
    check_accepted(s);
  }
  SECTION("1. quick-stop deceleration: m a <= 0.8 F") {
    EnvelopeSettings s = default_settings();
    s.quick_stop_limits.deceleration_m_per_s2 = kJustPast * kStopForceShare * force_N / m;
    check_refused(s, "motion.quick_stop_deceleration_m_per_s2");
    s.quick_stop_limits.deceleration_m_per_s2 = kJustInside * kStopForceShare * force_N / m;
    check_accepted(s);
  }
  SECTION("2. jerk: m j <= F / (2 periods)") {
    EnvelopeSettings s = default_settings();
    const double bound = force_N / (m * kMinForceRiseCycles * 1e-3);
    s.quick_stop_limits.jerk_m_per_s3 = kJustPast * bound;
    check_refused(s, "motion.quick_stop_jerk_m_per_s3");
    s.quick_stop_limits.jerk_m_per_s3 = kJustInside * bound;
    check_accepted(s);
  }
  SECTION("3. velocity: a quick stop from it within half the soft span") {
    // With the jerk high enough to ignore, the distance is v^2 / (2 a):
    // v = sqrt(2 a · 0.11 m) at the bound.
    EnvelopeSettings s = default_settings();
    s.quick_stop_limits = {20.0, 1e9 / 1e3};  // 1e6 m/s^3: the jerk phase is negligible
    s.stop_limits.jerk_m_per_s3 = 2000.0;
    s.motion_limits.jerk_m_per_s3 = 2000.0;
    const double bound = std::sqrt(2.0 * 20.0 * 0.11);
    s.motion_limits.velocity_m_per_s = 1.01 * bound;
    // The jerk of 1e6 is itself outside relation 2 on this machine: use a lighter, stronger one.
    const Machine strong{1.0, -0.12, 0.12};
    s.force_limit_N = 1e4;
    std::string reason = check_envelope(strong, s);
    INFO("past: " << reason);
    CHECK(reason.find("motion.velocity_m_per_s") != std::string::npos);
    s.motion_limits.velocity_m_per_s = 0.99 * bound;
    reason = check_envelope(strong, s);
    INFO("inside: " << reason);
    CHECK(reason.empty());
  }
  SECTION("3. a quick stop from full speed and full acceleration: the acceleration it must take away counts") {
    // The settings that walked the axis into its end stop: a quick stop at
    // 3.9e-4 m/s^2 and 0.00216 m/s^3 from 4.6 mm/s looks short (v^2/(2d),
    // 27 mm), but a move may be accelerating at 0.009 m/s^2 when it starts:
    // the stop gains a^2/(2j) = 18.8 mm/s before it can brake, and then needs
    // more than (v + a^2/(2j))^2/(2d) of travel.
    EnvelopeSettings s = default_settings();
    s.motion_limits = {0.0046, 0.009, 17920.0};
    s.stop_limits = {7.2e-6, 3.5e-6};
    s.quick_stop_limits = {3.9e-4, 0.00216};
    const double v = 0.0046, a = 0.009, d = 3.9e-4, j = 0.00216;
    CHECK(v * v / (2 * d) < 0.11);                                  // from the velocity alone: inside
    CHECK(std::pow(v + a * a / (2 * j), 2) / (2 * d) > 0.11);      // with the acceleration: far outside
    check_refused(s, "motion.acceleration_m_per_s2 0.009 m/s^2: a quick stop from them");
    s.motion_limits.acceleration_m_per_s2 = 1e-5;  // a^2/(2j) = 2.3e-8 m/s: the velocity's bound again
    s.motion_limits.jerk_m_per_s3 = 1.0;
    check_accepted(s);
  }
  SECTION("4. feedforward mass 0 or within a factor 2, friction within half the force") {
    EnvelopeSettings s = default_settings();
    for (const double mass : {7.5, 15.0, 30.0, 0.0}) {
      s.feedforward.mass_kg = mass;
      check_accepted(s);
    }
    for (const double mass : {7.4, 30.1, -15.0}) {
      s.feedforward.mass_kg = mass;
      check_refused(s, "control.feedforward.mass_kg");
    }
    s.feedforward.mass_kg = 15.0;
    s.feedforward.coulomb_N = 200.0;
    s.feedforward.viscous_N_s_per_m = (kJustPast * 300.0 - 200.0) / 0.5;
    check_refused(s, "control.feedforward");
    s.feedforward.viscous_N_s_per_m = (kJustInside * 300.0 - 200.0) / 0.5;
    check_accepted(s);
  }
  SECTION("5. following error: the soft limits inside the stroke by twice it") {
    EnvelopeSettings s = default_settings();
    s.following_error_limit_m = kJustPast * 0.005;  // inside by 0.01 m
    check_refused(s, "control.following_error_limit_m");
    s.following_error_limit_m = kJustInside * 0.005;
    check_accepted(s);
    s.soft_limit_max_m = 0.125;  // beyond the stroke: inside by a negative distance
    check_refused(s, "control.following_error_limit_m");
  }
  SECTION("6. saturation time within one period and 1 s") {
    EnvelopeSettings s = default_settings();
    s.saturation_time_limit_s = kJustPast * kMaxSaturationTime_s;
    check_refused(s, "control.saturation_time_limit_s");
    s.saturation_time_limit_s = kJustInside * kMaxSaturationTime_s;
    check_accepted(s);
    s.saturation_time_limit_s = 0.5e-3;
    check_refused(s, "control.saturation_time_limit_s");
  }
}

TEST_CASE("relation 7: the loop holds the feedforward's friction terms within the following-error limit",
          "[envelope]") {
  // The combination the property test found within relations 1-6: Coulomb
  // feedforward 112 N against a 1 Hz loop ran the translator into its end stop.
  EnvelopeSettings found = default_settings();
  found.pid = tune_pid(15.0, 1.0);
  found.feedforward.coulomb_N = 112.0;
  check_refused(found, "control.bandwidth_hz");
  // The bound from its formula: (viscous v_max + Coulomb) / k_p = e_max.
  EnvelopeSettings s = default_settings();
  s.feedforward.coulomb_N = 10.0;
  s.feedforward.viscous_N_s_per_m = 20.0;  // 10 N at 0.5 m/s
  const double needed_N_per_m = 20.0 / s.following_error_limit_m;
  s.pid.proportional_N_per_m = needed_N_per_m * kJustPast;  // stiffer: accepted
  check_accepted(s);
  s.pid.proportional_N_per_m = needed_N_per_m * kJustInside;
  check_refused(s, "control.bandwidth_hz");
  // No friction terms: any loop holds them (the mass term is relation 4's).
  s.feedforward.coulomb_N = s.feedforward.viscous_N_s_per_m = 0.0;
  s.pid = tune_pid(15.0, 1.0);
  check_accepted(s);
}
