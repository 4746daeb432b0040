#pragma once
// clm-servod configuration (config/servod.yaml, docs/servod.md): one YAML
// file, SI units in every key, every key with a default or a clear error,
// unknown keys refused. Errors name file, line and key path.

#include <string>

#include "commutation/commutator.hpp"
#include "commutation/model_file.hpp"
#include "daemon/servo/servo_cycle.hpp"

namespace clm::servod {

enum class ClockMode { kRealtime, kVirtual };

struct LoopConfig {
  double rate_hz = 1000.0;
  ClockMode clock = ClockMode::kRealtime;
  int priority = 80;                  ///< SCHED_FIFO priority; 0 leaves the scheduler alone
  int cpu = -1;                       ///< CPU for the loop thread; −1: no affinity
  bool lock_memory = true;            ///< mlockall(MCL_CURRENT | MCL_FUTURE)
  bool require_realtime = false;      ///< refuse to start without SCHED_FIFO and mlockall
  double receive_window_fraction = 0.5;  ///< feedback must arrive within this share of the period
};

struct CanConfig {
  std::string interface = "sim";      ///< "sim" (embedded simulated motor) or a SocketCAN interface
  double bitrate_bps = 1e6;
  double bus_load_limit = 0.7;
  double bus_load = 0.0;              ///< computed worst-case load of the cycle's schedule [-]
};

struct CommutationConfig {
  servo::CommutationMode mode = servo::CommutationMode::kOriginal;
  std::string calibration_file;       ///< classical law; empty: none
  std::string pgnn_model_file;
  std::string spline_model_file;
  ModelCommutatorOptions options;
};

struct TelemetryConfig {
  bool enabled = true;
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";
  int state_decimation = 1;
  double status_rate_hz = 10.0;
};

struct ServodConfig {
  std::string origin;                 ///< the config file
  std::string motor_file;             ///< absolute path
  MotorDescription motor;
  LoopConfig loop;
  CanConfig can;
  CommutationConfig commutation;
  TelemetryConfig telemetry;
  servo::ServoSettings servo;         ///< period, protocol, gains, limits
  double control_bandwidth_hz = 40.0;
  double control_mass_kg = 0.0;
  std::string feedforward_file;
};

/// Reads and validates the file; relative paths are resolved against its
/// directory. Throws yaml::Error with file, line and key path.
ServodConfig load_servod_config(const std::string& path);
ServodConfig parse_servod_config(const yaml::Node& root, const std::string& directory);

}  // namespace clm::servod
