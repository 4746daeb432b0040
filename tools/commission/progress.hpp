#pragma once
// The progress of a live commissioning, for `clm commission --live --resume
// DIR` (docs/commissioning.md, "Resuming"): after each identification
// experiment that completed, DIR/commission-progress.yaml (written
// atomically) lists it with its log (logs/experiment-K.lcm, the run's
// messages) and that log's SHA-256, beside the daemon's configuration and
// motor (path and SHA-256, from its status) and the experiment program's
// SHA-256 it ran with. A resumed commissioning reuses the experiments listed
// whose logs still have their SHA-256, on the same daemon configuration,
// motor and program, and runs the others; the identification and every law's
// evaluation run again.

#include <string>
#include <vector>

#include "clm_lcm/servo_status_t.hpp"
#include "tools/commission/runs.hpp"

namespace clm::commission {

inline constexpr const char* kProgressFile = "commission-progress.yaml";

/// What the runs were made with: the daemon's configuration and motor as its
/// status names them, and the experiment program.
struct RunIdentity {
  std::string configuration_file, configuration_sha256;
  std::string motor_file, motor_sha256;
  std::string experiment_program_sha256;
};

/// The identity of runs on the daemon whose `status` this is, with the
/// experiment program at `experiment_program_path` (read for its SHA-256).
RunIdentity run_identity(const clm_lcm::servo_status_t& status, const std::string& experiment_program_path);

struct CompletedExperiment {
  int coil_set = 0;
  double delta_rad = 0.0;
  std::string log;     ///< relative to the output directory
  std::string sha256;  ///< of the log
};

struct CommissionProgress {
  RunIdentity identity;
  std::vector<CompletedExperiment> experiments;  ///< in the order they ran
};

/// Writes `progress` to DIR/kProgressFile (temporary file, then rename).
void write_progress(const std::string& dir, const CommissionProgress& progress);
/// Reads DIR/kProgressFile; throws yaml::Error (file, line, key) when it is
/// not one, std::runtime_error when it is missing.
CommissionProgress read_progress(const std::string& dir);

/// "" when the progress in `dir` can be resumed by a daemon of `identity`:
/// the same configuration, motor and experiment program SHA-256, every
/// listed log present with its SHA-256; else the refusal with the fix.
std::string check_resume(const std::string& dir, const RunIdentity& identity);

/// The recording of a completed experiment from its log: the states of the
/// running program with the axis enabled (as LcmRunner keeps them), with
/// their damping and force-limited cycles. Throws std::runtime_error naming
/// the log when it has none.
Recording read_experiment_recording(const std::string& log_path, const std::string& name);

/// Copies every event of the logs `parts`, in order, into one LCM log at
/// `path` (written atomically).
void concatenate_logs(const std::vector<std::string>& parts, const std::string& path);

}  // namespace clm::commission
