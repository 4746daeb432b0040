#include "daemon/control/homing.hpp"

#include "commutation/encoder_reference.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace clm::control {

static_assert(kReferenceMethods.size() == static_cast<std::size_t>(HomingMethod::kHardStop) + 1,
              "kReferenceMethods names every HomingMethod, in its order");

const char* name(HomingMethod method) noexcept {
  const auto index = static_cast<std::size_t>(method);
  return index < kReferenceMethods.size() ? kReferenceMethods[index].data() : "?";
}

void HomingSettings::validate() const {
  const auto fail = [](const std::string& what, double value, const std::string& rule) {
    throw std::invalid_argument("homing." + what + ": " + std::to_string(value) + " " + rule);
  };
  if (direction != 1 && direction != -1) fail("direction", direction, "must be +1 or -1");
  if (!(search_velocity_m_per_s > 0.0 && search_velocity_m_per_s <= 0.1)) {
    fail("search_velocity_m_per_s", search_velocity_m_per_s, "must lie in (0, 0.1] m/s");
  }
  if (!(search_distance_m > 0.0 && search_distance_m <= 10.0)) {
    fail("search_distance_m", search_distance_m, "must lie in (0, 10] m");
  }
  if (!std::isfinite(reference_position_m)) fail("reference_position_m", reference_position_m, "must be finite");
  if (index_in_switch && method != HomingMethod::kReferenceSwitch) {
    throw std::invalid_argument("homing.index_in_switch: true needs method reference_switch, got " +
                                std::string(name(method)));
  }
  if (!(hard_stop_force_N > 0.0 && hard_stop_force_N <= 10000.0)) {
    fail("hard_stop_force_N", hard_stop_force_N, "must lie in (0, 10000] N");
  }
  if (!(hard_stop_following_error_m > 0.0 && hard_stop_following_error_m <= 0.01)) {
    fail("hard_stop_following_error_m", hard_stop_following_error_m, "must lie in (0, 0.01] m");
  }
  if (!(back_off_m > 0.0 && back_off_m <= 0.1)) fail("back_off_m", back_off_m, "must lie in (0, 0.1] m");
  finding.validate();
}

SearchProfile SearchProfile::plan(double start_m, double velocity_m_per_s, const StopLimits& limits) noexcept {
  SearchProfile profile;
  profile.start_m_ = start_m;
  profile.velocity_m_per_s_ = velocity_m_per_s;
  profile.relative_ = StopProfile::plan({0.0, -velocity_m_per_s, 0.0, 0.0}, limits);
  return profile;
}

ReferenceSample SearchProfile::sample(double t_s) const noexcept {
  ReferenceSample relative = relative_.sample(t_s);
  return {start_m_ + velocity_m_per_s_ * t_s + relative.position_m, velocity_m_per_s_ + relative.velocity_m_per_s,
          relative.acceleration_m_per_s2, relative.jerk_m_per_s3};
}

}  // namespace clm::control
