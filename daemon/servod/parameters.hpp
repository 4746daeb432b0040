#pragma once
// The run-time parameters of clm-servod (docs/servod.md, "Run-time
// parameters"): a documented subset of the configuration that `clm ctl set`
// changes while the daemon runs, at standstill, and `clm ctl save` writes back.
// Each is named by its configuration key and read from the configuration with
// the same range (servod_config.cpp uses this table), so a value set at run
// time is checked exactly as one in the file.

#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "daemon/control/loop_analysis.hpp"
#include "daemon/servo/servo_cycle.hpp"

namespace clm::servod {

struct RuntimeParameter {
  const char* key;   ///< configuration key, e.g. "control.bandwidth_hz"
  const char* unit;  ///< SI unit as in the key's suffix
  double min;        ///< smallest value accepted
  double max;        ///< largest value accepted; for control.bandwidth_hz the loop rate's sixth caps it further
};

/// Every run-time parameter, in the order `clm ctl get` lists them.
std::span<const RuntimeParameter> runtime_parameters() noexcept;
/// The parameter named `key`, or nullptr.
const RuntimeParameter* find_runtime_parameter(std::string_view key) noexcept;

/// What the run-time parameters are set from: the tuning and the two numbers
/// the PID gains are tuned from (control::tune_pid).
struct RuntimeValues {
  servo::Tuning tuning;
  double mass_kg = 0.0;       ///< control.mass_kg (fixed at start-up)
  double bandwidth_hz = 0.0;  ///< control.bandwidth_hz
};

/// The value of `parameter` in `values`.
double parameter_value(const RuntimeValues& values, const RuntimeParameter& parameter) noexcept;

/// `values` with `key` set to `value`, or the reason it is refused (unknown
/// key, outside the range, not finite, settings that ServoSettings::validate
/// refuses, e.g. a quick-stop deceleration below the stop's, or a bandwidth
/// whose loop keeps less than the least margins on `plant`). `base` is the
/// rest of the settings, `rate_hz` the loop rate, `plant` what the motor file
/// describes (ServodConfig::plant).
struct ParameterChange {
  std::optional<RuntimeValues> values;
  std::string refusal;
};
ParameterChange change_parameter(const RuntimeValues& values, const servo::ServoSettings& base, double rate_hz,
                                 const control::PlantModel& plant, std::string_view key, double value);

/// "control.bandwidth_hz = 40 Hz"-style text of a value, shortest round-trip digits.
std::string describe_parameter(const RuntimeParameter& parameter, double value);

}  // namespace clm::servod
