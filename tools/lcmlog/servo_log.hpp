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

/// Missing cycles first..last (inclusive): the states of those cycles that
/// would have been published are not in the log.
struct CycleRange {
  std::int64_t first = 0;
  std::int64_t last = 0;
  bool operator==(const CycleRange&) const = default;
};

/// Gaps in a sequence of CLM_SERVO_STATE cycle counters. Pure: no I/O.
struct CycleGaps {
  std::int64_t step_cycles = 1;      ///< cycles from one published state to the next (state_decimation)
  std::int64_t missing = 0;          ///< states missing: a step a → b misses (b − a)/step_cycles − 1
  std::int64_t gaps = 0;             ///< steps with states missing
  std::vector<CycleRange> listed;    ///< the first gaps, at most the `max_listed` asked for
  std::int64_t out_of_order = 0;     ///< a counter not above its predecessor (repeated, reordered, a daemon restart)
  std::int64_t pauses = 0;           ///< steps across a recording-resumed marker: not examined
};

/// The gaps of `cycles` (in file order) where each state should follow the one
/// before by `step_cycles`. `resumed` lists, ascending, the indices k whose
/// step from k − 1 is a pause of the recording (telemetry::kRecordingResumedEvent),
/// not examined. Lists the first `max_listed` gaps; counts all.
CycleGaps find_cycle_gaps(std::span<const std::int64_t> cycles, std::int64_t step_cycles,
                          std::span<const std::size_t> resumed = {}, int max_listed = 5);

/// The listed gaps as "12, 15..19" (cycle numbers), with ", ... and 36 more
/// gaps" when not all are listed; "" when there is none.
std::string describe_ranges(const CycleGaps& gaps);

/// The step between published states that `cycles` show: the greatest common
/// divisor of the increasing steps (pauses left out), 1 when there is none.
/// clm-servod publishes every state_decimation-th cycle, which no state carries.
std::int64_t published_step_cycles(std::span<const std::int64_t> cycles, std::span<const std::size_t> resumed = {});

/// What a log says about its own completeness (docs/telemetry.md, "Gaps").
struct LogGaps {
  CycleGaps cycles;                    ///< in the cycle counter of the states
  std::int64_t statuses = 0;           ///< CLM_SERVO_STATUS messages in the log
  /// Growth of servo_status_t.telemetry_dropped over the log: the messages the
  /// daemon itself dropped (its queues full). Summed per daemon session; a
  /// session that starts within the log counts from its start.
  std::int64_t daemon_dropped = 0;
  /// True when states are missing, out of order, or the daemon dropped messages.
  bool any() const { return cycles.missing > 0 || cycles.out_of_order > 0 || daemon_dropped > 0; }
};

/// One line (no prefix, no newline) describing `gaps` of the log at `path`,
/// e.g. "run.lcm: 93 CLM_SERVO_STATE messages missing in 41 gaps (cycles 12,
/// 15..19, ... and 36 more gaps); the daemon counted 0 telemetry messages
/// dropped (servo_status_t.telemetry_dropped over 85 statuses)". "" when !gaps.any().
std::string describe_gaps(const std::string& path, const LogGaps& gaps);

/// Every CLM_SERVO_STATE message of the log at `lcm_log_path`, in file order,
/// as records (telemetry::to_record); other channels are skipped, except that
/// CLM_SERVO_STATUS and CLM_SERVO_EVENT are checked and read for the gaps
/// (read_servo_state_log). Throws std::runtime_error with one line naming
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
///   "run.lcm: no CLM_SERVO_STATE message (an empty file)"
///   "run.lcm: no CLM_SERVO_STATE message among 12 events"
std::vector<servo::CycleRecord> read_servo_states(const std::string& lcm_log_path, const data::DataLimits& limits = {});

/// The CLM_SERVO_STATE messages of a log with the event number of each, and
/// what the log shows of messages lost on the way.
struct ServoStateLog {
  std::vector<servo::CycleRecord> states;
  std::vector<std::int64_t> events;  ///< events[k]: event number of states[k] (0-based, every channel)
  LogGaps gaps;
};
/// As read_servo_states, keeping each state's event number and the log's gaps;
/// the same errors, and also for a CLM_SERVO_STATUS or CLM_SERVO_EVENT message
/// that fails telemetry::decode_checked:
///   "run.lcm: event 17: CLM_SERVO_STATUS: <the wire check's reason>"
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
/// ib_A are the commanded currents. Fy_N, Fx_N, Tz_Nm when every such state
/// measured a force, none when no state did (an axis without a force
/// sensor). Throws std::invalid_argument when no state is in experiment mode
/// or only some measured a force.
CsvColumns experiment_columns(std::span<const servo::CycleRecord> states);

/// Feedforward identification data for `clm ff-identify`: every state.
CsvColumns feedforward_columns(std::span<const servo::CycleRecord> states);

/// Every field of every state. utime is exact (< 2^53 µs); booleans are 0/1;
/// coil-set columns run to the largest coil_sets in the log, NaN where a
/// state has fewer coil sets.
CsvColumns full_columns(std::span<const servo::CycleRecord> states);

CsvColumns to_csv_columns(std::span<const servo::CycleRecord> states, CsvFormat format);

}  // namespace clm::lcmlog
