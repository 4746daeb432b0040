#include "daemon/servod/parameters.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <stdexcept>

namespace clm::servod {
namespace {

constexpr std::array<RuntimeParameter, 15> kParameters{{
    {"control.bandwidth_hz", "Hz", 1.0, 1e4},
    {"control.feedforward.mass_kg", "kg", 0.0, 1e4},
    {"control.feedforward.viscous_N_s_per_m", "N*s/m", 0.0, 1e5},
    {"control.feedforward.coulomb_N", "N", 0.0, 1e4},
    {"control.following_error_limit_m", "m", 1e-7, 1.0},
    {"control.force_limit_N", "N", 1.0, 819.0},
    {"control.saturation_time_limit_s", "s", 0.0, 10.0},
    {"motion.velocity_m_per_s", "m/s", 1e-6, 100.0},
    {"motion.acceleration_m_per_s2", "m/s^2", 1e-6, 1e4},
    {"motion.jerk_m_per_s3", "m/s^3", 1e-6, 1e8},
    {"motion.stop_deceleration_m_per_s2", "m/s^2", 1e-6, 1e4},
    {"motion.stop_jerk_m_per_s3", "m/s^3", 1e-6, 1e8},
    {"motion.quick_stop_deceleration_m_per_s2", "m/s^2", 1e-6, 1e4},
    {"motion.quick_stop_jerk_m_per_s3", "m/s^3", 1e-6, 1e8},
    // Not tunable at run time: the mass the gains are tuned for is the mechanics'.
    {"control.mass_kg", "kg", 0.0, 0.0},
}};
// The last entry is read-only (min == max == 0): listed, never set.
constexpr std::size_t kTunable = kParameters.size() - 1;

/// The field of `values` (const or not) that entry `index` of kParameters names.
template <typename Values>
auto field(Values& values, std::size_t index) noexcept -> decltype(&values.bandwidth_hz) {
  auto& t = values.tuning;
  switch (index) {
    case 0: return &values.bandwidth_hz;
    case 1: return &t.feedforward.mass_kg;
    case 2: return &t.feedforward.viscous_N_s_per_m;
    case 3: return &t.feedforward.coulomb_N;
    case 4: return &t.following_error_limit_m;
    case 5: return &t.force_limit_N;
    case 6: return &t.saturation_time_limit_s;
    case 7: return &t.motion_limits.velocity_m_per_s;
    case 8: return &t.motion_limits.acceleration_m_per_s2;
    case 9: return &t.motion_limits.jerk_m_per_s3;
    case 10: return &t.stop_limits.deceleration_m_per_s2;
    case 11: return &t.stop_limits.jerk_m_per_s3;
    case 12: return &t.quick_stop_limits.deceleration_m_per_s2;
    case 13: return &t.quick_stop_limits.jerk_m_per_s3;
    case 14: return &values.mass_kg;
  }
  return nullptr;
}

std::string shortest(double value) {
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, value);
  return std::string(text, result.ptr);
}

}  // namespace

std::span<const RuntimeParameter> runtime_parameters() noexcept { return kParameters; }

const RuntimeParameter* find_runtime_parameter(std::string_view key) noexcept {
  for (const auto& parameter : kParameters) {
    if (key == parameter.key) return &parameter;
  }
  return nullptr;
}

double parameter_value(const RuntimeValues& values, const RuntimeParameter& parameter) noexcept {
  const auto index = static_cast<std::size_t>(&parameter - kParameters.data());
  return *field(values, index);
}

ParameterChange change_parameter(const RuntimeValues& values, const servo::ServoSettings& base, double rate_hz,
                                 const control::PlantModel& plant, std::string_view key, double value) {
  const RuntimeParameter* parameter = find_runtime_parameter(key);
  if (parameter == nullptr) return {std::nullopt, "unknown parameter '" + std::string(key) + "' (clm ctl get lists them)"};
  const auto index = static_cast<std::size_t>(parameter - kParameters.data());
  if (index >= kTunable) return {std::nullopt, std::string(key) + " is fixed at start-up (the configuration file)"};
  double max = parameter->max;
  if (index == 0) max = std::min(max, rate_hz / 6.0);  // as the configuration: a sixth of the loop rate
  if (!std::isfinite(value) || value < parameter->min || value > max) {
    return {std::nullopt, std::string(key) + ": expected a number in [" + shortest(parameter->min) + ", " +
                              shortest(max) + "] " + parameter->unit + ", got " + shortest(value)};
  }
  RuntimeValues changed = values;
  *field(changed, index) = value;
  try {
    changed.tuning.pid = control::tune_pid(changed.mass_kg, changed.bandwidth_hz);
    servo::ServoSettings settings = base;
    settings.apply(changed.tuning);
    settings.validate();
    // Only the bandwidth moves the gains at run time (control.mass_kg is fixed).
    if (changed.bandwidth_hz != values.bandwidth_hz) {
      if (const std::string shortfall = control::margin_shortfall(changed.tuning.pid, 1.0 / rate_hz, plant);
          !shortfall.empty()) {
        return {std::nullopt, std::string(key) + " = " + shortest(value) + ": the position loop would be " + shortfall +
                                  " on the plant the motor file describes"};
      }
    }
  } catch (const std::invalid_argument& e) {
    return {std::nullopt, std::string(key) + " = " + shortest(value) + ": " + e.what()};
  }
  return {changed, ""};
}

std::string describe_parameter(const RuntimeParameter& parameter, double value) {
  return std::string(parameter.key) + " = " + shortest(value) + " " + parameter.unit;
}

}  // namespace clm::servod
