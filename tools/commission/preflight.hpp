#pragma once
// What `clm commission --live` checks before its first experiment, in one
// place (docs/commissioning.md, "Checks before the first experiment"): every
// check that could otherwise fail minutes later. Each refusal is one
// sentence with the reason and the fix; all of them are said at once.
//   - the output directory: among the daemon's commands.file_directories
//     (servod::check_output_directory), and enough free space for the logs
//     and data of every run (estimate_output_bytes);
//   - every program (experiments, evaluation, validation) admitted by the
//     daemon's own move decision (servo::decide_move: soft limits, motion
//     limits, the stop from every cycle), and within control.force_limit_N
//     at control.mass_kg;
//   - the daemon: the configuration's axis and motor, the drive profile of
//     its states (the coil sets and the period LcmRunner::enable checks);
//   - the timing margin: the drive's watchdog and faults.overrun_limit
//     against the daemon's measured wake-up latency and overruns, over the
//     commissioning's expected duration (servo::judge_timing_margin, the
//     rule the daemon's start-up warning uses).
// Pure apart from reading the program files and the free space of --out.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "clm_lcm/servo_state_t.hpp"
#include "clm_lcm/servo_status_t.hpp"
#include "daemon/servod/program_file.hpp"
#include "daemon/servod/servod_config.hpp"

namespace clm::commission {

struct Options;

/// A program commissioning runs, and how often.
struct PlannedProgram {
  std::string what;  ///< "experiment program", "evaluation program", "validation program"
  std::string path;  ///< absolute
  servod::ProgramFile program;
  int runs = 0;      ///< how many runs of it commissioning makes at most
};

/// The absolute paths of the programs `options` names (the defaults beside
/// the configuration: programs/fig8.yaml, identification.yaml,
/// validation.yaml); validation "" for "none".
struct ProgramPaths {
  std::string evaluation, experiment, validation;
};
ProgramPaths program_paths(const Options& options);

/// The programs of a commissioning of `config` with `options`, each with the
/// most runs it gets: the experiment program 2 per coil set, the evaluation
/// program 2 per law evaluated (its feedforward data and its evaluation), the
/// validation program 1 per law. Throws as load_program_file on a bad file.
std::vector<PlannedProgram> planned_programs(const Options& options, const servod::ServodConfig& config);

/// Bytes a run of one state costs in --out: the encoded CLM_SERVO_STATE with
/// its LCM log header, and a CSV row of up to 12 columns.
std::int64_t bytes_per_state();
/// Estimated bytes commissioning writes: every planned run's states (its
/// duration and 1 s, at the configuration's rate) at bytes_per_state(), twice
/// over, plus kFixedOutputBytes for the models, reports and plots.
std::int64_t estimate_output_bytes(const std::vector<PlannedProgram>& programs, double period_s);
inline constexpr std::int64_t kFixedOutputBytes = 16ll << 20;

/// The expected wall time of commissioning [s]: every planned run with the
/// move to its start and the settling (kRunOverhead_s), and
/// kIdentificationAllowance_s for the identification, during which the axis
/// stays enabled.
double expected_duration_s(const std::vector<PlannedProgram>& programs);
inline constexpr double kRunOverhead_s = 5.0;
inline constexpr double kIdentificationAllowance_s = 600.0;

/// What the daemon showed before anything was commanded.
struct DaemonView {
  clm_lcm::servo_status_t status{};
  std::optional<clm_lcm::servo_state_t> state;  ///< a CLM_SERVO_STATE, when one came
};

/// Every refusal of a live commissioning of `config` with `options` on the
/// daemon `daemon`, each with its reason and its fix; empty when all pass.
/// `available_bytes`: the free space of --out (its nearest existing
/// directory), or nullopt to read it.
std::vector<std::string> live_preflight(const servod::ServodConfig& config, const Options& options,
                                        const DaemonView& daemon,
                                        std::optional<std::int64_t> available_bytes = std::nullopt);

/// The refusals as the one error line: "live commissioning refused before
/// the first experiment (N problems): 1) ...; 2) ...".
std::string describe_refusals(const std::vector<std::string>& refusals);

}  // namespace clm::commission
