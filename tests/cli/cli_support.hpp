#pragma once
// Process-level tests of `clm`: run the real binary (no shell), capture its
// exit status, stdout and stderr, and look at the files it leaves.

#include <set>
#include <string>
#include <vector>

#include "support/temporary_directory.hpp"

namespace clm::cli_test {

struct ProcessResult {
  int exit_code = -1;  ///< exit status, or 128 + signal number
  std::string out, err;
  /// stderr split at '\n' (a last line without '\n' counts too).
  std::vector<std::string> err_lines() const;
};

/// Runs `binary` with `args` via posix_spawn; stdout and stderr go to files
/// in a directory of this process's own, never to the directory under test.
ProcessResult run_program(const std::string& binary, const std::vector<std::string>& args);
/// run_program of build/bin/clm (CLM_BINARY).
ProcessResult run_clm(const std::vector<std::string>& args);
/// run_program of build/bin/clm-servod (CLM_SERVOD_BINARY).
ProcessResult run_servod(const std::vector<std::string>& args);

/// A fresh directory under the system's temporary directory, removed with
/// everything in it on destruction (tests/support).
using test::TemporaryDirectory;

/// Names of the entries of `directory` (not recursive).
std::set<std::string> listing(const std::string& directory);
std::string read_file(const std::string& path);
void write_file(const std::string& path, const std::string& content);
/// `relative` inside the source tree (CLM_SOURCE_DIR).
std::string source_path(const std::string& relative);

/// A CSV as lines; line k of the file is lines[k − 1] (line 1 is the header).
using CsvLines = std::vector<std::string>;
std::string join_lines(const CsvLines& lines);
/// Replaces the cell of `column` in file line `line_number`.
void set_cell(CsvLines& lines, std::size_t line_number, const std::string& column, const std::string& text);
/// Removes `column` from every line.
void drop_column(CsvLines& lines, const std::string& column);
/// Index of `column` in the header.
std::size_t column_index(const CsvLines& lines, const std::string& column);

/// A small, well-formed experiment CSV for a motor with `coil_sets` coil sets
/// (pole pitch 0.03 m): per coil set, `rows_per_offset` rows at Δ = −π/4, then
/// as many at +π/4, rows ordered by coil set. Enough to be read; bad-input
/// tests corrupt it.
CsvLines synthetic_experiment_lines(int coil_sets, int rows_per_offset = 8);
/// t_s, r_m, F_star_N of a short move.
CsvLines synthetic_feedforward_lines(int rows = 50);

/// The commissioning experiments of the default motor (config/servod.yaml),
/// run on the daemon core, as the files the tests read: the tools'
/// experiments.csv, every 10th row of it, the daemon's LCM log of the same
/// runs, and t_s, r_m, F_star_N of the first run (closed-loop data).
struct ExperimentFiles {
  std::string csv;    ///< t_s, coil_set, delta_rad, magnitude_N, y_m, Fy_N, Fx_N, Tz_Nm
  std::string tenth;  ///< every 10th row of each run of csv
  std::string lcm;    ///< every cycle of the runs as CLM_SERVO_STATE (and status/events)
  std::string closed_loop;  ///< t_s, r_m, F_star_N of the first run
};
/// The files in `directory`; a marker written last says they are complete.
ExperimentFiles experiment_files_in(const std::string& directory);
/// Runs the experiments and writes experiment_files_in(directory), each file
/// whole or not at all, the marker last.
void write_experiment_files(const std::string& directory);
/// The experiments' files: those the CTest fixture cli_experiments wrote
/// (CLM_TEST_EXPERIMENTS names their directory; once per build tree, not per
/// test process), else written once per process into a temporary directory.
const ExperimentFiles& experiment_files();

}  // namespace clm::cli_test
