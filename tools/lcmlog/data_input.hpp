#pragma once
// The --data input of `clm calibrate`, `clm identify` and `clm ff-identify`:
// a CSV file, or an LCM log of clm-servod recognised by its first bytes and
// converted to the same columns (docs/data-formats.md), so that both take the
// same validation and the same code path.

#include <CLI/CLI.hpp>
#include <string>

#include "tools/data/csv_table.hpp"
#include "tools/lcmlog/servo_log.hpp"

namespace clm::lcmlog {

/// True when the file at `path` begins with the LCM log sync word 0xEDA1DA01
/// (big-endian, as lcm-logger and LcmLogWriter write it), whatever its name.
/// False for a shorter file; throws std::runtime_error if it cannot be opened
/// or is not a regular file (clm::open_regular_file, without blocking).
bool is_lcm_log(const std::string& path);

/// What a subcommand that reads LCM logs does when a log has gaps
/// (LogGaps::any): warn, or with --fail-on-gaps refuse.
struct GapPolicy {
  std::string subcommand;     ///< names the lines: "clm <subcommand>: warning: ..."
  bool fail_on_gaps = false;  ///< --fail-on-gaps
};

/// Registers --fail-on-gaps on `subcommand`, bound to `policy`, and names
/// `policy` after it.
void add_gap_option(CLI::App& subcommand, GapPolicy& policy);

/// The one report of a log's gaps, the same for every subcommand: nothing
/// when there are none; else one line on stderr, "clm <subcommand>: warning:
/// <describe_gaps>", or with policy.fail_on_gaps "clm <subcommand>: error:
/// <describe_gaps> (--fail-on-gaps)" and CLI::RuntimeError(1) thrown (a
/// refusal at run time: exit status 1, nothing written).
void report_gaps(const std::string& lcm_log_path, const LogGaps& gaps, const GapPolicy& policy);

/// A CSV file as CsvTable::load, or an LCM log (is_lcm_log) whose
/// CLM_SERVO_STATE messages are converted to `format`'s columns
/// (experiment_columns, feedforward_columns) without a text round trip; rows
/// of a log are named by event number in later errors ("run.lcm: event 1742:
/// column 'Fy_N': 'nan' is not a finite number"). Throws std::runtime_error
/// with one line naming the file (and the event for a damaged log), also for
/// a file that is not a regular file or holds more than `limits` allow. The
/// gaps of a log are reported by report_gaps with `gaps` before its rows are
/// converted.
data::CsvTable load_data_table(const std::string& path, CsvFormat format, const data::DataLimits& limits = {},
                               const GapPolicy& gaps = {});

/// CLI11 check of an input file option: the path must exist, whatever it is.
/// What it is (only a regular file is read) and its size are checked when it
/// is opened (clm::open_regular_file), so that a directory, a device or a FIFO
/// gets the same one-line refusal, and status 2, as any other bad input.
CLI::Validator existing_input_file();

/// Registers --max-bytes and --max-rows on `subcommand`, bound to `limits`
/// (defaults DataLimits's), for the data file given by `file_option` ("--data").
void add_data_limit_options(CLI::App& subcommand, data::DataLimits& limits, const std::string& file_option);

}  // namespace clm::lcmlog
