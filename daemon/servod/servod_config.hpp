#pragma once
// clm-servod configuration (config/servod.yaml, docs/servod.md): one YAML
// file, SI units in every key, every key with a default or a clear error,
// unknown keys refused. Errors name file, line and key path.

#include <cstdint>
#include <string>
#include <vector>

#include "commutation/commutator.hpp"
#include "commutation/law_check.hpp"
#include "commutation/model_file.hpp"
#include "daemon/control/loop_analysis.hpp"
#include "daemon/servo/servo_cycle.hpp"
#include "drivers/sim/in_process_bus.hpp"

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

/// What is at the other end of the axis's CAN bus. The configuration reader
/// decides it once from can.interface (kSimulatedInterface, or any other
/// name); everything after reads this, never the name.
enum class BusKind {
  kSimulated,  ///< the embedded simulated motor (motor_file) on an in-process bus
  kSocketCan,  ///< the SocketCAN interface CanConfig::interface
};

/// The can.interface that names the embedded simulated motor.
inline constexpr const char* kSimulatedInterface = "sim";

struct CanConfig {
  BusKind bus = BusKind::kSimulated;  ///< from `interface`, by the configuration reader
  std::string interface = kSimulatedInterface;  ///< as configured: "sim" or a SocketCAN interface name
  double bitrate_bps = 1e6;
  double bus_load_limit = 0.7;
  double bus_load = 0.0;              ///< computed worst-case load of the cycle's schedule [-]
  /// BusKind::kSimulated only: fault injection fired step by step by SIGUSR1
  /// (docs/reliability.md, "Fault injection on the embedded simulated motor").
  std::vector<sim::PlannedStep> sim_fault_plan;
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
  /// A udpm URL with ttl above 0 sends telemetry and takes commands beyond
  /// this host; refused unless this is set (docs/telemetry.md).
  bool allow_network = false;
  int state_decimation = 1;
  double status_rate_hz = 10.0;
};

/// Who may command the axis and what it may load (docs/servod.md, "Command
/// authority" and "Files").
struct CommandsConfig {
  double max_age_s = 2.0;             ///< older commands are refused [s]
  double control_lease_s = 30.0;      ///< control lapses this long after the holder's last command [s]
  double deadman_timeout_s = 1.0;     ///< a deadman lease (renew_control) lapses this long after the holder's last command [s]
  /// Directories (canonical, absolute) that model, calibration, feedforward
  /// and program files are loaded from; default: the config file's directory.
  std::vector<std::string> file_directories;
  std::int64_t max_file_bytes = 16 << 20;  ///< larger files are refused before they are read [B]
  /// The operators' key (config/command_key.hpp), read at start-up by the
  /// daemon (with telemetry on) only; absolute, or relative to the config
  /// file's directory. Default: clm::default_command_key_path().
  std::string key_file;
};

struct ServodConfig {
  std::string origin;                 ///< the config file
  std::string origin_sha256;          ///< of the bytes read (64 hex digits)
  std::string axis_name = "axis0";    ///< names the axis in commands and status
  std::string motor_file;             ///< absolute path
  std::string motor_sha256;           ///< of motor_file's bytes as read
  MotorDescription motor;
  LoopConfig loop;
  CanConfig can;
  CommutationConfig commutation;
  TelemetryConfig telemetry;
  CommandsConfig commands;
  servo::ServoSettings servo;         ///< period, protocol, gains, limits
  double control_bandwidth_hz = 40.0;
  double control_mass_kg = 0.0;
  /// The plant the motor file describes, for control.mass_kg: every tuning of
  /// the loop, at start-up and by `set`, keeps the least margins on it.
  control::PlantModel plant;
  std::string feedforward_file;
};

/// Reads and validates the file; relative paths are resolved against its
/// directory. Throws yaml::Error with file, line and key path.
ServodConfig load_servod_config(const std::string& path);

/// The reference this axis homes to (homing:), as calibration and model
/// files record theirs (docs/model-format.md, "The encoder reference").
EncoderReference encoder_reference(const ServodConfig& config);
ServodConfig parse_servod_config(const yaml::Node& root, const std::string& directory);

/// The ttl of a udpm:// LCM URL (LCM's default, 0, when it names none);
/// −1 for a URL of another provider. Throws std::invalid_argument for a ttl
/// that is not a whole number in 0..255.
int lcm_url_ttl(const std::string& url);

/// What the daemon checks a law against (commutation/law_check.hpp): the
/// loop's rate, the drive's nominal motor constant and the stroke.
LawLimits law_limits(const ServodConfig& config);

}  // namespace clm::servod
