#pragma once
// The commissioning experiments of Algorithms 1 and 2, run on the daemon core
// with its embedded simulated motor on the virtual clock, as `clm commission`
// runs them: each coil set alone, Δ = −π/4 then +π/4, on the experiment
// program (programs/fig8.yaml beside the configuration, fitted to the soft
// limits), no feedforward. For tests and benchmarks that need real data
// without depending on files another run left behind.

#include <string>
#include <vector>

#include "commutation/model_file.hpp"
#include "tools/commission/runs.hpp"

namespace clm::test {

struct DaemonExperiments {
  MotorDescription motor;
  std::vector<commission::Recording> runs;  ///< 2 per coil set: l = 1 (−π/4, +π/4), l = 2, ...
};

/// Runs the experiments on the configuration at `servod_config_path` (its
/// can.interface must be sim). With `lcm_log_path` set, every cycle of the
/// runs is also written there as the daemon's telemetry (TelemetryBridge on
/// an LcmLogWriter, state_decimation 1). Throws std::runtime_error on a
/// refused command or a fault.
DaemonExperiments run_daemon_experiments(const std::string& servod_config_path, const std::string& lcm_log_path = "");

/// The columns of the tools' experiment CSV as `clm commission` writes
/// experiments.csv: t_s, coil_set, delta_rad, magnitude_N, y_m, Fy_N, Fx_N,
/// Tz_Nm (no currents: the tools reconstruct them, eq. 19). Of each run, the
/// first `samples_per_run` samples (all when 0), then every `every_nth`.
struct ExperimentColumns {
  std::vector<std::string> names;
  std::vector<std::vector<double>> values;  ///< values[column][row]
};
ExperimentColumns experiment_columns(const DaemonExperiments& experiments, std::size_t samples_per_run = 0,
                                     std::size_t every_nth = 1);

}  // namespace clm::test
