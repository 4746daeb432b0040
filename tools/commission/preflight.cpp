#include "tools/commission/preflight.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "daemon/control/trajectory.hpp"
#include "daemon/servo/move_decision.hpp"
#include "daemon/servo/timing.hpp"
#include "daemon/servod/file_policy.hpp"
#include "daemon/telemetry/telemetry.hpp"
#include "tools/commission/commission.hpp"
#include "tools/commission/progress.hpp"
#include "tools/servod_client/config_update.hpp"

namespace clm::commission {
namespace {

std::string megabytes(std::int64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f MB", static_cast<double>(bytes) * 1e-6);
  return text;
}

std::string six_digits(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

/// The free space of `directory`, or of its nearest existing parent (--out
/// is created later); -1 when it cannot be read.
std::int64_t free_bytes(const std::string& directory) {
  std::filesystem::path path = std::filesystem::absolute(directory).lexically_normal();
  std::error_code error;
  while (!path.empty() && !std::filesystem::exists(path, error)) {
    if (path == path.parent_path()) break;
    path = path.parent_path();
  }
  const std::filesystem::space_info space = std::filesystem::space(path, error);
  if (error) return -1;
  return static_cast<std::int64_t>(space.available);
}

/// "" when the daemon's move decision admits `program` run from its own
/// start (the axis enabled, at rest there), else its refusal.
std::string check_program(const PlannedProgram& planned, const servod::ServodConfig& config) {
  servo::AxisSnapshot axis;
  axis.state = servo::ServoState::kEnabled;
  axis.at_rest = true;
  axis.hold_position_m = planned.program.start_m;
  servo::Command command;
  command.kind = servo::CommandKind::kRunProgram;
  const servo::MoveDecision decision = servo::decide_move(
      config.servo, axis, command, {planned.program.start_m, planned.program.steps});
  if (decision.program) {
    // The force the program's largest acceleration takes at the mass the
    // loop is tuned for: beyond control.force_limit_N the cycle limits F*
    // and the tracking error grows until a fault.
    double acceleration_m_per_s2 = 0.0;
    for (const auto& step : planned.program.steps) {
      acceleration_m_per_s2 = std::max(acceleration_m_per_s2, step.limits.acceleration_m_per_s2);
    }
    const double force_N = config.control_mass_kg * acceleration_m_per_s2;
    if (config.control_mass_kg > 0.0 && force_N >= config.servo.force_limit_N) {
      return "the " + planned.what + " " + planned.path + " accelerates at up to " + six_digits(acceleration_m_per_s2) +
             " m/s^2, which takes " + six_digits(force_N) + " N at control.mass_kg " + six_digits(config.control_mass_kg) +
             " kg, at or beyond control.force_limit_N " + six_digits(config.servo.force_limit_N) +
             " N. Fix: lower the program's acceleration_m_per_s2, or raise control.force_limit_N within the drive's "
             "current limit";
    }
    return "";
  }
  return "the " + planned.what + " " + planned.path + " is refused by the daemon's limits (" + config.origin +
         "): " + decision.detail + " (" + servo::describe(decision.result) +
         "). Fix: give a program within the soft limits and the motion: limits (docs/servod.md, \"Programs\"), or "
         "widen those limits in the configuration";
}

}  // namespace

ProgramPaths program_paths(const Options& options) {
  const std::string config_dir = std::filesystem::absolute(options.config_path).parent_path().string();
  const auto absolute = [](const std::string& path) {
    return std::filesystem::absolute(path).lexically_normal().string();
  };
  ProgramPaths paths;
  paths.evaluation = absolute(options.program_path.empty() ? config_dir + "/programs/fig8.yaml" : options.program_path);
  paths.experiment = absolute(options.experiment_program_path.empty() ? config_dir + "/programs/identification.yaml"
                                                                      : options.experiment_program_path);
  if (options.validation_program_path != "none") {
    paths.validation = absolute(options.validation_program_path.empty() ? config_dir + "/programs/validation.yaml"
                                                                        : options.validation_program_path);
  }
  return paths;
}

std::vector<PlannedProgram> planned_programs(const Options& options, const servod::ServodConfig& config) {
  const ProgramPaths paths = program_paths(options);
  const bool sensor = can::has_force_sensor(config.servo.protocol);
  // Live, the oracle is not run: original, the force laws (classical, the
  // paper's PGNN, the chosen PGNN, spline) with a sensor, classical from
  // positions without one, and the spline from positions (at most).
  const int laws = 1 + (sensor ? 4 : 0) + (options.no_force_sensor ? 1 : 0) + 1;
  std::vector<PlannedProgram> programs;
  programs.push_back({"experiment program", paths.experiment, servod::load_program_file(paths.experiment),
                      2 * config.motor.coil_sets});
  programs.push_back({"evaluation program", paths.evaluation, servod::load_program_file(paths.evaluation), 2 * laws});
  if (!paths.validation.empty()) {
    programs.push_back({"validation program", paths.validation, servod::load_program_file(paths.validation), laws});
  }
  return programs;
}

std::int64_t bytes_per_state() {
  const clm_lcm::servo_state_t state{};
  // LCM log event header: sync word, event number, timestamp, channel and
  // data lengths (28 bytes), then the channel's name.
  const std::int64_t log_bytes = 28 + static_cast<std::int64_t>(std::string(telemetry::kStateChannel).size()) +
                                 state.getEncodedSize();
  constexpr std::int64_t kCsvRowBytes = 12 * 24;  // up to 12 columns of %.17g and a separator
  return log_bytes + kCsvRowBytes;
}

std::int64_t estimate_output_bytes(const std::vector<PlannedProgram>& programs, double period_s) {
  double states = 0.0;
  for (const auto& planned : programs) {
    const double duration_s = control::MoveProgram(planned.program.start_m, planned.program.steps).duration_s();
    states += planned.runs * (duration_s + 1.0) / period_s;
  }
  return 2 * static_cast<std::int64_t>(std::ceil(states)) * bytes_per_state() + kFixedOutputBytes;
}

double expected_duration_s(const std::vector<PlannedProgram>& programs) {
  double total_s = kIdentificationAllowance_s;
  for (const auto& planned : programs) {
    const double duration_s = control::MoveProgram(planned.program.start_m, planned.program.steps).duration_s();
    total_s += planned.runs * (duration_s + kRunOverhead_s);
  }
  return total_s;
}

std::vector<std::string> live_preflight(const servod::ServodConfig& config, const Options& options,
                                        const DaemonView& daemon, std::optional<std::int64_t> available_bytes) {
  std::vector<std::string> refusals;
  // The daemon loads what is written to --out.
  const std::string out_refusal = servod::check_output_directory(
      {config.commands.file_directories, config.commands.max_file_bytes}, options.out_dir);
  if (!out_refusal.empty()) refusals.push_back("--out " + out_refusal);

  // The configuration must be the daemon's: everything below reads it.
  try {
    servod_client::require_daemons_configuration(config, daemon.status);
  } catch (const std::exception& e) {
    refusals.push_back(e.what());
    return refusals;
  }

  // --resume: the completed experiments were made on this daemon's
  // configuration and motor with this experiment program, and are intact.
  if (options.resume) {
    std::string refusal;
    try {
      refusal = check_resume(options.out_dir, run_identity(daemon.status, program_paths(options).experiment));
    } catch (const std::exception& e) {
      refusal = std::string("--resume: ") + e.what();
    }
    if (!refusal.empty()) refusals.push_back(refusal);
  }

  std::vector<PlannedProgram> programs;
  try {
    programs = planned_programs(options, config);
  } catch (const std::exception& e) {
    refusals.push_back(std::string(e.what()) + ". Fix: give a readable program file (docs/servod.md, \"Programs\")");
    return refusals;
  }
  for (const auto& planned : programs) {
    const std::string refusal = check_program(planned, config);
    if (!refusal.empty()) refusals.push_back(refusal);
  }

  const std::int64_t needed = estimate_output_bytes(programs, config.servo.period_s);
  const std::int64_t available = available_bytes ? *available_bytes : free_bytes(options.out_dir);
  if (available >= 0 && available < needed) {
    int runs = 0;
    for (const auto& planned : programs) runs += planned.runs;
    refusals.push_back("--out " + options.out_dir + ": " + megabytes(available) + " free, commissioning writes up to " +
                       megabytes(needed) + " (" + std::to_string(runs) + " runs' states at " +
                       std::to_string(bytes_per_state()) + " bytes each in logs and CSV, twice over, and " +
                       megabytes(kFixedOutputBytes) + " of models and reports). Fix: free space there, or give an "
                       "--out on a file system with room (and among commands.file_directories)");
  }

  if (daemon.state) {
    const auto profile = static_cast<DriveProfile>(daemon.state->drive_profile);
    if (profile != config.motor.drive_profile) {
      refusals.push_back(std::string("clm-servod's axis '") + daemon.status.axis + "' sends " + name(profile) +
                         " setpoints, the motor file " + config.motor_file + " says drive.profile " +
                         name(config.motor.drive_profile) +
                         ": experiments would be read with the wrong drive model. Fix: restart the daemon on this "
                         "configuration, or give --config the daemon's");
    }
  }

  const servo::MeasuredTiming measured{config.servo.period_s, daemon.status.wakeup_latency_p99_s,
                                       daemon.status.wakeup_latency_max_s, daemon.status.cycles,
                                       daemon.status.overruns};
  const servo::TimingLimits limits{config.motor.drive_watchdog_timeout_s, config.servo.overrun_limit,
                                   expected_duration_s(programs)};
  const servo::TimingMargin margin = servo::judge_timing_margin(measured, limits);
  if (!margin.watchdog.empty()) refusals.push_back(margin.watchdog + " (" + config.motor_file + ")");
  if (!margin.overrun.empty()) refusals.push_back(margin.overrun + " (" + config.origin + ")");
  return refusals;
}

std::string describe_refusals(const std::vector<std::string>& refusals) {
  std::string text = "live commissioning refused before the first experiment (" + std::to_string(refusals.size()) +
                     (refusals.size() == 1 ? " problem): " : " problems): ");
  for (std::size_t k = 0; k < refusals.size(); ++k) {
    text += (k == 0 ? "" : "; ") + std::to_string(k + 1) + ") " + refusals[k];
  }
  return text;
}

}  // namespace clm::commission
