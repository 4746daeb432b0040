#include "tools/lcmlog/servo_log.hpp"

#include "tools/lcmlog/state_fields.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "commutation/types.hpp"
#include "daemon/telemetry/lcm_conversion.hpp"
#include "daemon/telemetry/messages.hpp"
#include "daemon/telemetry/wire_check.hpp"
#include "config/regular_file.hpp"

namespace clm::lcmlog {
namespace {

using telemetry::kEventChannel;
using telemetry::kStateChannel;
using telemetry::kStatusChannel;
constexpr std::size_t kEventHeaderBytes = 4 + 8 + 8 + 4 + 4;
constexpr std::uint64_t kSyncWord = 0xEDA1DA01;
// lcm's own reader refuses channel names of 1000 bytes or more.
constexpr std::int32_t kMaxChannelBytes = 1000;

std::uint64_t big_endian(const std::uint8_t* bytes, int count) {
  std::uint64_t value = 0;
  for (int i = 0; i < count; ++i) value = (value << 8) | bytes[i];
  return value;
}

std::string event_prefix(const std::string& path, std::int64_t event) {
  return path + ": event " + std::to_string(event) + ": ";
}

void check_state(const clm_lcm::servo_state_t& state, const std::string& path, std::int64_t event) {
  const auto fail = [&](const std::string& what) {
    throw std::runtime_error(event_prefix(path, event) + kStateChannel + ": " + what);
  };
  if (state.coil_sets < 0 || state.coil_sets > kMaxCoilSets) {
    fail("coil_sets " + std::to_string(state.coil_sets) + " outside 0.." + std::to_string(kMaxCoilSets));
  }
  if (state.coil_set < 0 || state.coil_set > state.coil_sets) {
    fail("coil_set " + std::to_string(state.coil_set) + " outside 0.." + std::to_string(state.coil_sets) +
         " (coil_sets)");
  }
}

/// Reads a RegularFile through a buffer of 1 MiB: events are small.
class BufferedReader {
 public:
  explicit BufferedReader(RegularFile& file) : file_(file), buffer_(std::size_t{1} << 20) {}

  /// Copies the next `count` bytes to `out`; false if the file ended first.
  bool read(void* out, std::size_t count) {
    auto* to = static_cast<std::uint8_t*>(out);
    while (count > 0) {
      if (position_ == filled_) {
        if (count >= buffer_.size()) return file_.read(to, count) == count;
        filled_ = file_.read(buffer_.data(), buffer_.size());
        position_ = 0;
        if (filled_ == 0) return false;
      }
      const std::size_t take = std::min(count, filled_ - position_);
      std::memcpy(to, buffer_.data() + position_, take);
      position_ += take;
      to += take;
      count -= take;
    }
    return true;
  }

 private:
  RegularFile& file_;
  std::vector<std::uint8_t> buffer_;
  std::size_t position_ = 0;
  std::size_t filled_ = 0;
};

/// The growth of servo_status_t.telemetry_dropped over the statuses of a log,
/// fed in file order.
class DaemonDropCount {
 public:
  void add(const clm_lcm::servo_status_t& status) {
    ++statuses_;
    if (statuses_ > 1 && status.session == session_ && status.telemetry_dropped >= last_) {
      growth_ += status.telemetry_dropped - last_;
    } else if (statuses_ > 1) {
      // Another session: that daemon started within the log, and every drop it counted happened in it.
      growth_ += std::max<std::int64_t>(0, status.telemetry_dropped);
    }
    session_ = status.session;
    last_ = status.telemetry_dropped;
  }
  std::int64_t statuses() const { return statuses_; }
  std::int64_t growth() const { return growth_; }

 private:
  std::int64_t statuses_ = 0;
  std::int64_t session_ = 0;
  std::int64_t last_ = 0;
  std::int64_t growth_ = 0;
};

/// True at the steps that find_cycle_gaps examines.
class StepFilter {
 public:
  explicit StepFilter(std::span<const std::size_t> resumed) : resumed_(resumed) {}
  /// Whether the step into state k (k ascending from 1) is a pause.
  bool pause(std::size_t k) {
    while (next_ < resumed_.size() && resumed_[next_] < k) ++next_;
    return next_ < resumed_.size() && resumed_[next_] == k;
  }

 private:
  std::span<const std::size_t> resumed_;
  std::size_t next_ = 0;
};

}  // namespace

CycleGaps find_cycle_gaps(std::span<const std::int64_t> cycles, std::int64_t step_cycles,
                          std::span<const std::size_t> resumed, int max_listed) {
  CycleGaps gaps;
  gaps.step_cycles = std::max<std::int64_t>(1, step_cycles);
  StepFilter filter(resumed);
  for (std::size_t k = 1; k < cycles.size(); ++k) {
    if (filter.pause(k)) {
      ++gaps.pauses;
      continue;
    }
    const std::int64_t step = cycles[k] - cycles[k - 1];
    if (step <= 0) {
      ++gaps.out_of_order;
      continue;
    }
    if (step <= gaps.step_cycles) continue;
    // A step that is not a multiple of step_cycles still misses the states in between.
    gaps.missing += (step - 1) / gaps.step_cycles;
    if (gaps.gaps < max_listed) gaps.listed.push_back({cycles[k - 1] + gaps.step_cycles, cycles[k] - gaps.step_cycles});
    ++gaps.gaps;
  }
  return gaps;
}

std::int64_t published_step_cycles(std::span<const std::int64_t> cycles, std::span<const std::size_t> resumed) {
  std::int64_t step_cycles = 0;
  StepFilter filter(resumed);
  for (std::size_t k = 1; k < cycles.size(); ++k) {
    const std::int64_t step = cycles[k] - cycles[k - 1];
    if (!filter.pause(k) && step > 0) step_cycles = std::gcd(step_cycles, step);
  }
  return std::max<std::int64_t>(1, step_cycles);
}

std::string describe_ranges(const CycleGaps& gaps) {
  std::string text;
  for (const CycleRange& range : gaps.listed) {
    if (!text.empty()) text += ", ";
    text += std::to_string(range.first);
    if (range.last != range.first) text += ".." + std::to_string(range.last);
  }
  const auto unlisted = gaps.gaps - static_cast<std::int64_t>(gaps.listed.size());
  if (unlisted > 0) text += ", ... and " + std::to_string(unlisted) + " more " + (unlisted == 1 ? "gap" : "gaps");
  return text;
}

std::string describe_gaps(const std::string& path, const LogGaps& gaps) {
  if (!gaps.any()) return "";
  const CycleGaps& c = gaps.cycles;
  std::string line = path + ": ";
  if (c.missing > 0) {
    line += std::to_string(c.missing) + " " + kStateChannel + (c.missing == 1 ? " message" : " messages") +
            " missing in " + std::to_string(c.gaps) + (c.gaps == 1 ? " gap" : " gaps") + " (cycles " +
            describe_ranges(c) + ")";
    if (c.step_cycles > 1) line += " among states every " + std::to_string(c.step_cycles) + " cycles";
  } else {
    line += std::string("no ") + kStateChannel + " message missing";
  }
  if (c.out_of_order > 0) {
    line += "; " + std::to_string(c.out_of_order) +
            " cycle counters not above the one before (repeated, reordered, or the daemon restarted)";
  }
  if (gaps.statuses == 0) {
    line += std::string("; the daemon's own drop count is unknown (no ") + kStatusChannel + " in the log)";
  } else {
    line += "; the daemon counted " + std::to_string(gaps.daemon_dropped) +
            " telemetry messages dropped (servo_status_t.telemetry_dropped over " + std::to_string(gaps.statuses) +
            (gaps.statuses == 1 ? " status)" : " statuses)");
  }
  return line;
}

std::vector<servo::CycleRecord> read_servo_states(const std::string& lcm_log_path, const data::DataLimits& limits) {
  return read_servo_state_log(lcm_log_path, limits).states;
}

ServoStateLog read_servo_state_log(const std::string& lcm_log_path, const data::DataLimits& limits) {
  // The log format (lcm/eventlog.c), every integer big-endian:
  //   sync 0xEDA1DA01 (4), event number (8), timestamp [µs] (8),
  //   channel length (4), data length (4), channel, data.
  // Read here rather than through lcm::LogFile, whose reader stops quietly at
  // damage (blaming the event before it) and prints to stderr. Only a regular
  // file of at most limits.max_bytes is read (a FIFO is refused, not waited on).
  RegularFile file = open_regular_file(lcm_log_path, limits.max_bytes, " for an LCM log (--max-bytes raises it)");
  const std::uint64_t file_bytes = file.size_bytes();
  BufferedReader in(file);

  ServoStateLog log;
  std::vector<std::uint8_t> data;
  std::string channel;
  std::uint64_t offset = 0;
  DaemonDropCount daemon_drops;
  std::vector<std::size_t> resumed;  // states that follow a recording-resumed marker
  std::int64_t event = 0;
  for (; offset < file_bytes; ++event) {
    const auto fail = [&](const std::string& what) {
      throw std::runtime_error(event_prefix(lcm_log_path, event) + what);
    };
    std::array<std::uint8_t, kEventHeaderBytes> header{};
    if (file_bytes - offset < kEventHeaderBytes) {
      fail("truncated: " + std::to_string(file_bytes - offset) + " bytes at byte " + std::to_string(offset) +
           ", less than an event header");
    }
    if (!in.read(header.data(), kEventHeaderBytes)) fail("read error at byte " + std::to_string(offset));
    if (big_endian(header.data(), 4) != kSyncWord) {
      fail("no LCM sync word at byte " + std::to_string(offset) + " (corrupt log, or not an LCM log)");
    }
    const auto channel_length = static_cast<std::int32_t>(big_endian(header.data() + 20, 4));
    const auto data_length = static_cast<std::int32_t>(big_endian(header.data() + 24, 4));
    if (channel_length <= 0 || channel_length >= kMaxChannelBytes) {
      fail("channel length " + std::to_string(channel_length) + " outside 1.." + std::to_string(kMaxChannelBytes - 1) +
           " (corrupt log)");
    }
    if (data_length < 0) fail("negative data length " + std::to_string(data_length) + " (corrupt log)");
    const std::uint64_t body = static_cast<std::uint64_t>(channel_length) + static_cast<std::uint64_t>(data_length);
    if (file_bytes - offset - kEventHeaderBytes < body) {
      fail("truncated: the event at byte " + std::to_string(offset) + " needs " + std::to_string(body) +
           " bytes after its header, the file has " + std::to_string(file_bytes - offset - kEventHeaderBytes));
    }
    channel.resize(static_cast<std::size_t>(channel_length));
    data.resize(static_cast<std::size_t>(data_length));
    if (!in.read(channel.data(), channel.size()) || !in.read(data.data(), data.size())) {
      fail("read error at byte " + std::to_string(offset));
    }
    offset += kEventHeaderBytes + body;

    const auto decode = [&](auto& message) {
      const std::string reason = telemetry::decode_checked(std::span<const std::uint8_t>(data), message);
      if (!reason.empty()) fail(channel + ": " + reason);
    };
    if (channel == kStatusChannel) {
      clm_lcm::servo_status_t status;
      decode(status);
      daemon_drops.add(status);
      continue;
    }
    if (channel == kEventChannel) {
      clm_lcm::servo_event_t marker;
      decode(marker);
      if (marker.code == telemetry::kRecordingResumedEvent &&
          (resumed.empty() || resumed.back() != log.states.size())) {
        resumed.push_back(log.states.size());
      }
      continue;
    }
    if (channel != kStateChannel) continue;
    clm_lcm::servo_state_t state;
    if (state.decode(data.data(), 0, data_length) != data_length) fail(std::string("cannot decode ") + kStateChannel);
    check_state(state, lcm_log_path, event);
    if (log.states.size() == limits.max_rows) {
      fail("more than " + std::to_string(limits.max_rows) + " " + kStateChannel +
           " messages, the limit (--max-rows raises it)");
    }
    try {
      log.states.push_back(telemetry::to_record(state));
    } catch (const std::invalid_argument& e) {
      fail(std::string(kStateChannel) + ": " + e.what());
    }
    log.events.push_back(event);
  }
  if (log.states.empty()) {
    const std::string where = event == 0 ? "(an empty file)" : "among " + std::to_string(event) + " events";
    throw std::runtime_error(lcm_log_path + ": no " + kStateChannel + " message " + where);
  }
  std::vector<std::int64_t> cycles(log.states.size());
  for (std::size_t k = 0; k < cycles.size(); ++k) cycles[k] = log.states[k].cycle;
  log.gaps.cycles = find_cycle_gaps(cycles, published_step_cycles(cycles, resumed), resumed);
  log.gaps.statuses = daemon_drops.statuses();
  log.gaps.daemon_dropped = daemon_drops.growth();
  return log;
}

CsvFormat parse_csv_format(std::string_view name) {
  if (name == "experiment") return CsvFormat::kExperiment;
  if (name == "feedforward") return CsvFormat::kFeedforward;
  if (name == "full") return CsvFormat::kFull;
  throw std::invalid_argument("unknown CSV format '" + std::string(name) + "' (experiment, feedforward, full)");
}

namespace {

/// Builds columns row by row: add(name, value) in the same order each row.
class ColumnBuilder {
 public:
  void begin_row(std::size_t source_state) {
    column_ = 0;
    columns_.source_states.push_back(source_state);
  }
  void add(const std::string& name, double value) {
    if (rows_ == 0) {
      columns_.names.push_back(name);
      columns_.values.emplace_back();
    }
    columns_.values[column_++].push_back(value);
  }
  void end_row() { ++rows_; }
  CsvColumns finish(std::initializer_list<const char*> names_if_empty) {
    if (rows_ == 0) {
      for (const char* name : names_if_empty) {
        columns_.names.emplace_back(name);
        columns_.values.emplace_back();
      }
    }
    return std::move(columns_);
  }

 private:
  CsvColumns columns_;
  std::size_t column_ = 0;
  std::size_t rows_ = 0;
};

}  // namespace

CsvColumns experiment_columns(std::span<const servo::CycleRecord> states) {
  // The force columns when every experiment state measured a force; none
  // from an axis without a force sensor (docs/data-formats.md).
  std::size_t experiment_states = 0, measured = 0;
  for (const auto& s : states) {
    if (s.commutation != servo::CommutationMode::kExperiment || s.coil_set < 1) continue;
    ++experiment_states;
    if (s.force_measured) ++measured;
  }
  if (measured != 0 && measured != experiment_states) {
    throw std::invalid_argument(std::to_string(experiment_states - measured) + " of " +
                                std::to_string(experiment_states) +
                                " states in experiment mode carry no force measurement (force_measured false): the "
                                "force columns would hold zeros there");
  }
  const bool forces = measured != 0;
  ColumnBuilder out;
  for (std::size_t k = 0; k < states.size(); ++k) {
    const auto& s = states[k];
    if (s.commutation != servo::CommutationMode::kExperiment || s.coil_set < 1) continue;
    const auto l = static_cast<std::size_t>(s.coil_set - 1);
    out.begin_row(k);
    out.add("t_s", s.t_s);
    out.add("coil_set", s.coil_set);
    out.add("delta_rad", s.delta_rad);
    out.add("magnitude_N", s.magnitude_N.at(l));
    out.add("y_m", s.y_m);
    if (forces) {
      out.add("Fy_N", s.Fy_N);
      out.add("Fx_N", s.Fx_N);
      out.add("Tz_Nm", s.Tz_Nm);
    }
    out.add("ia_A", s.ia_A.at(l));
    out.add("ib_A", s.ib_A.at(l));
    out.end_row();
  }
  auto columns = out.finish({});
  if (columns.rows() == 0) {
    throw std::invalid_argument("no state in experiment mode (commutation 5 with a coil set) among " +
                                std::to_string(states.size()) + " CLM_SERVO_STATE messages");
  }
  return columns;
}

CsvColumns feedforward_columns(std::span<const servo::CycleRecord> states) {
  ColumnBuilder out;
  for (std::size_t k = 0; k < states.size(); ++k) {
    const auto& s = states[k];
    out.begin_row(k);
    out.add("t_s", s.t_s);
    out.add("r_m", s.r_m);
    out.add("F_star_N", s.F_star_N);
    out.end_row();
  }
  return out.finish({"t_s", "r_m", "F_star_N"});
}

CsvColumns full_columns(std::span<const servo::CycleRecord> states) {
  int coil_sets = 0;
  for (const auto& s : states) coil_sets = std::max(coil_sets, static_cast<int>(s.coil_sets));
  CsvColumns out;
  for (const StateField& field : state_fields(coil_sets)) {
    std::vector<double> column;
    column.reserve(states.size());
    for (const auto& s : states) column.push_back(field.value(s));
    out.names.push_back(field.name);
    out.values.push_back(std::move(column));
  }
  out.source_states.resize(states.size());
  for (std::size_t k = 0; k < states.size(); ++k) out.source_states[k] = k;
  return out;
}

CsvColumns to_csv_columns(std::span<const servo::CycleRecord> states, CsvFormat format) {
  switch (format) {
    case CsvFormat::kExperiment:
      return experiment_columns(states);
    case CsvFormat::kFeedforward:
      return feedforward_columns(states);
    case CsvFormat::kFull:
      break;
  }
  return full_columns(states);
}

}  // namespace clm::lcmlog
