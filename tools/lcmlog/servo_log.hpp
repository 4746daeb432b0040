#pragma once
// clm-servod's LCM logs (written by lcm-logger or clm::telemetry::LcmLogWriter)
// read back and turned into the tools' CSV column sets (docs/data-formats.md,
// docs/telemetry.md).

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/servo/cycle_record.hpp"
#include "tools/data/csv_table.hpp"

namespace clm::lcmlog {

/// Every CLM_SERVO_STATE message of the log at `lcm_log_path`, in file order,
/// as records (telemetry::to_record); other channels are skipped. Throws std::runtime_error with one line naming
/// the file and the event (0-based, counting every channel, as lcm-logplayer):
///   "run.lcm: cannot open: No such file or directory"
///   "run.lcm: not a regular file (a FIFO); only regular files are read"
///   "run.lcm: 3000000000 bytes, more than the limit of 2147483648 bytes for an LCM log (--max-bytes raises it)"
///   "run.lcm: event 17: more than 10000000 CLM_SERVO_STATE messages, the limit (--max-rows raises it)"
///   "run.lcm: event 17: cannot decode CLM_SERVO_STATE"
///   "run.lcm: event 17: CLM_SERVO_STATE: coil_sets 9 outside 0..8"
///   "run.lcm: event 17: CLM_SERVO_STATE: commutation 7 outside 0..5"
///   "run.lcm: event 17: no LCM sync word at byte 5120 (corrupt log, or not an LCM log)"
///   "run.lcm: event 17: truncated: the event at byte 5120 needs 415 bytes after its header, the file has 12"
std::vector<servo::CycleRecord> read_servo_states(const std::string& lcm_log_path, const data::DataLimits& limits = {});

/// The CLM_SERVO_STATE messages of a log with the event number of each.
struct ServoStateLog {
  std::vector<servo::CycleRecord> states;
  std::vector<std::int64_t> events;  ///< events[k]: event number of states[k] (0-based, every channel)
};
/// As read_servo_states, keeping each state's event number; same errors.
ServoStateLog read_servo_state_log(const std::string& lcm_log_path, const data::DataLimits& limits = {});

/// Named columns of equal length, ready for clm::data::write_csv_atomically.
struct CsvColumns {
  std::vector<std::string> names;
  std::vector<std::vector<double>> values;  ///< values[column][row]
  std::vector<std::size_t> source_states;   ///< index in the input states of each row
  std::size_t rows() const { return values.empty() ? 0 : values.front().size(); }
};

enum class CsvFormat {
  kExperiment,   ///< t_s, coil_set, delta_rad, magnitude_N, y_m, Fy_N, Fx_N, Tz_Nm, ia_A, ib_A
  kFeedforward,  ///< t_s, r_m, F_star_N
  kFull,         ///< every field; per coil set l: magnitude_N_<l>, setpoint_delta_rad_<l>, ia_A_<l>, ib_A_<l>
};

/// "experiment", "feedforward", "full" → CsvFormat; std::invalid_argument otherwise.
CsvFormat parse_csv_format(std::string_view name);

/// Experiment data for `clm calibrate` / `clm identify`: one row per state in
/// experiment mode (commutation 5) with a coil set; magnitude_N, ia_A, ib_A
/// are those of the driven coil set, delta_rad the experiment's offset. ia_A,
/// ib_A are the commanded currents. Throws std::invalid_argument when no
/// state is in experiment mode.
CsvColumns experiment_columns(std::span<const servo::CycleRecord> states);

/// Feedforward identification data for `clm ff-identify`: every state.
CsvColumns feedforward_columns(std::span<const servo::CycleRecord> states);

/// Every field of every state. utime is exact (< 2^53 µs); booleans are 0/1;
/// coil-set columns run to the largest coil_sets in the log, NaN where a
/// state has fewer coil sets.
CsvColumns full_columns(std::span<const servo::CycleRecord> states);

CsvColumns to_csv_columns(std::span<const servo::CycleRecord> states, CsvFormat format);

}  // namespace clm::lcmlog
