#include "support/daemon_experiments.hpp"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>

#include "daemon/servod/axis_wiring.hpp"
#include "daemon/servod/program_file.hpp"
#include "daemon/servod/servod_config.hpp"
#include "daemon/servod/telemetry_bridge.hpp"
#include "daemon/telemetry/telemetry.hpp"

namespace clm::test {

DaemonExperiments run_daemon_experiments(const std::string& servod_config_path, const std::string& lcm_log_path) {
  using Kind = servo::CommandKind;
  servod::ServodConfig config = servod::load_servod_config(servod_config_path);
  config.loop.clock = servod::ClockMode::kVirtual;
  config.telemetry.enabled = false;
  config.commutation.mode = servo::CommutationMode::kOriginal;
  config.servo.feedforward = {};
  bool scaled = false;
  const std::string program_path =
      (std::filesystem::path(servod_config_path).parent_path() / "programs" / "fig8.yaml").string();
  const servod::ProgramFile program = servod::fit_program(
      servod::load_program_file(program_path), config.servo.soft_limit_min_m, config.servo.soft_limit_max_m, scaled);

  DaemonExperiments experiments;
  experiments.motor = config.motor;
  servod::WiredAxis axis(config);
  servod::ServoDaemon& daemon = axis.daemon;
  std::unique_ptr<telemetry::LcmLogWriter> log;
  std::optional<servod::TelemetryBridge> bridge;
  if (!lcm_log_path.empty()) {
    log = std::make_unique<telemetry::LcmLogWriter>(lcm_log_path);
    bridge.emplace(*log, daemon, 1);
  }
  daemon.run_cycles(20);
  commission::enable_homed(daemon);  // as clm commission does
  for (int l = 1; l <= config.motor.coil_sets; ++l) {
    for (double delta : {-kPi / 4, kPi / 4}) {
      servo::Command experiment;
      experiment.kind = Kind::kSetExperiment;
      experiment.coil_set = l;
      experiment.delta_rad = delta;
      commission::execute(daemon, experiment);
      if (log) {  // the log holds the runs only, as clm commission's do
        const auto& last = daemon.cycle().record();
        telemetry::mark_recording_resumed(*log, last.cycle, last.utime);
      }
      experiments.runs.push_back(commission::run_program(axis, program, "experiment coil set " + std::to_string(l),
                                                         bridge ? &*bridge : nullptr));
    }
  }
  if (log) log->close();
  return experiments;
}

ExperimentColumns experiment_columns(const DaemonExperiments& experiments, std::size_t samples_per_run,
                                     std::size_t every_nth) {
  ExperimentColumns out;
  out.names = {"t_s", "coil_set", "delta_rad", "magnitude_N", "y_m", "Fy_N", "Fx_N", "Tz_Nm"};
  out.values.resize(out.names.size());
  double offset_s = 0.0;  // runs follow each other in time, 1 s apart, as in clm commission
  for (const auto& run : experiments.runs) {
    const std::size_t n = samples_per_run == 0 ? run.samples.size() : std::min(samples_per_run, run.samples.size());
    for (std::size_t k = 0; k < n; k += std::max<std::size_t>(1, every_nth)) {
      const auto& s = run.samples[k];
      const auto l = static_cast<std::size_t>(s.coil_set - 1);
      const double row[] = {offset_s + s.program_time_s, static_cast<double>(s.coil_set), s.delta_rad,
                            s.magnitude_N[l], s.y_m, s.Fy_N, s.Fx_N, s.Tz_Nm};
      for (std::size_t c = 0; c < out.names.size(); ++c) out.values[c].push_back(row[c]);
    }
    if (!run.samples.empty()) offset_s += run.samples.back().program_time_s + 1.0;
  }
  return out;
}

}  // namespace clm::test
