// hil_fault_check: what the bus shows of each fault injected by `clm sim
// --inject` (docs/reliability.md), from a `candump -L` log and the
// simulator's event log, independently of the daemon's own account.
//
// Cycle k is the k-th SYNC of the log with the frames after it, which is the
// simulator's SYNC count k (the recorder starts before both processes). For
// each step the simulator fired at SYNC n it prints one line of key=value:
//
//   step=2 kind=drop-drive frames=3 sync=4711 seen_on_bus=1 enabled_before=1 max_setpoint_before_N=12.3
//   zero_after_cycles=3 enabled_after_cycles=2
//
// seen_on_bus: the injected defect is on the bus in cycles n … n+frames−1
// (the frame absent, late past the receive window, with a reserved bit, the
// wrong DLC, twice, with an alive jump of the drive or the force sensor, with a position jump, with the fault
// bit; for a push, the translator's speed from the drive's positions falling
// by at least kPushEvidence_m_per_s against the motion within the push's
// first 10 cycles); zero_after_cycles: the first cycle c ≥ n whose setpoints are all zero
// with ControlEnable cleared, as c − n + 1 (0: none within 2000 cycles);
// enabled_after_cycles: consecutive cycles from n on with ControlEnable set.
// For every watchdog expiry in the event log: whether the daemon's last RPDO1
// before the SYNCs stopped asked for enable and whether the drive's first
// feedback after they resumed reports the watchdog and the fault. With
// --flood-id, the frames of that identifier (count, rate, the bus load they
// would make at 1 Mbit/s) and the cycles they span; with --sim-killed, the
// cycles from the first without any feedback to zero setpoints.
//
// Exit status: 0 read and printed; 2 bad arguments or unreadable files.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/command_line.hpp"
#include "drivers/can/can_protocol.hpp"

namespace {

using clm::can::Frame;

struct Options {
  std::string log_path;
  std::string events_path;
  int coil_sets = 3;
  int drive_node_id = 1;
  int force_sensor_node_id = 2;
  double period_s = 1e-3;
  double receive_window_fraction = 0.5;
  std::string flood_id;  ///< hex, empty: none
  bool sim_killed = false;
};

struct TimedFrame {
  double time_s = 0.0;
  Frame frame;
  int order = 0;  ///< position within the cycle
};

struct Cycle {
  double sync_time_s = 0.0;
  std::vector<TimedFrame> frames;
};

bool parse_line(const std::string& line, double& time_s, Frame& frame) {
  if (line.empty() || line[0] != '(') return false;
  const auto close = line.find(") ");
  if (close == std::string::npos) return false;
  time_s = std::strtod(line.c_str() + 1, nullptr);
  const auto space = line.find(' ', close + 2);
  if (space == std::string::npos) return false;
  const std::string text = line.substr(space + 1);
  const auto hash = text.find('#');
  if (hash != 3) return false;  // standard data frames only
  frame.id = static_cast<std::uint32_t>(std::strtoul(text.substr(0, 3).c_str(), nullptr, 16));
  const std::string data = text.substr(hash + 1);
  if (data.size() % 2 != 0 || data.size() > 16) return false;
  frame.dlc = static_cast<std::uint8_t>(data.size() / 2);
  frame.data.fill(0);
  for (std::size_t k = 0; k < frame.dlc; ++k) {
    frame.data[k] = static_cast<std::uint8_t>(std::strtoul(data.substr(2 * k, 2).c_str(), nullptr, 16));
  }
  return true;
}

std::map<std::string, std::string> key_values(const std::string& line) {
  std::map<std::string, std::string> values;
  std::istringstream in(line);
  std::string item;
  while (in >> item) {
    const auto equals = item.find('=');
    if (equals != std::string::npos) values[item.substr(0, equals)] = item.substr(equals + 1);
  }
  return values;
}

class Bus {
 public:
  Bus(const Options& options, std::vector<Cycle> cycles) : options_(options), cycles_(std::move(cycles)) {
    protocol_.coil_sets = options.coil_sets;
    protocol_.drive_node_id = static_cast<std::uint8_t>(options.drive_node_id);
    protocol_.force_sensor_node_id = static_cast<std::uint8_t>(options.force_sensor_node_id);
  }

  int cycles() const { return static_cast<int>(cycles_.size()); }
  /// Frames of `id` in cycle k (1-based), in order.
  std::vector<const TimedFrame*> frames(int k, std::uint32_t id) const {
    std::vector<const TimedFrame*> found;
    if (k < 1 || k > cycles()) return found;
    for (const TimedFrame& f : cycles_[static_cast<std::size_t>(k - 1)].frames) {
      if (f.frame.id == id) found.push_back(&f);
    }
    return found;
  }
  const Cycle& cycle(int k) const { return cycles_[static_cast<std::size_t>(k - 1)]; }
  std::uint32_t drive_id() const { return clm::can::drive_feedback_id(protocol_); }
  std::uint32_t force_id() const { return clm::can::force_feedback_id(protocol_); }
  std::uint32_t setpoint_id(std::size_t index) const { return clm::can::setpoint_id(protocol_, index); }

  /// 1: ControlEnable set in the cycle's RPDO1; 0: cleared; −1: no RPDO1.
  int enabled(int k) const {
    const auto rpdo1 = frames(k, setpoint_id(0));
    if (rpdo1.empty()) return -1;
    return (rpdo1.front()->frame.data[0] & clm::can::kControlEnable) != 0 ? 1 : 0;
  }
  /// Every RPDO of the cycle present, magnitudes and offsets 0, enable cleared.
  bool zero_setpoints(int k) const {
    if (enabled(k) != 0) return false;
    for (std::size_t index = 0; index < clm::can::setpoint_frame_count(options_.coil_sets); ++index) {
      const auto rpdo = frames(k, setpoint_id(index));
      if (rpdo.empty()) return false;
      const Frame& f = rpdo.front()->frame;
      const std::size_t first = index == 0 ? 2 : 0;
      for (std::size_t b = first; b < f.dlc; ++b) {
        if (f.data[b] != 0) return false;
      }
    }
    return true;
  }
  /// Largest |magnitude| of any coil set in the cycle's RPDOs [N].
  double max_magnitude_N(int k) const {
    double largest = 0.0;
    const auto magnitude = [](const Frame& f, std::size_t byte) {
      return std::abs(static_cast<std::int16_t>(f.data[byte] | (f.data[byte + 1] << 8)) * 0.025);
    };
    for (const TimedFrame* f : frames(k, setpoint_id(0))) largest = std::max(largest, magnitude(f->frame, 2));
    if (options_.coil_sets >= 2) {
      for (const TimedFrame* f : frames(k, setpoint_id(1))) {
        largest = std::max({largest, magnitude(f->frame, 0), magnitude(f->frame, 4)});
      }
    }
    if (options_.coil_sets == 4) {
      for (const TimedFrame* f : frames(k, setpoint_id(2))) largest = std::max(largest, magnitude(f->frame, 0));
    }
    return largest;
  }
  int first_zero_from(int n) const {
    for (int k = n; k <= std::min(cycles(), n + 2000); ++k) {
      if (zero_setpoints(k)) return k - n + 1;
    }
    return 0;
  }
  int enabled_run_from(int n) const {
    int run = 0;
    for (int k = n; k <= cycles() && enabled(k) == 1; ++k) ++run;
    return run;
  }
  double window_s() const { return options_.receive_window_fraction * options_.period_s; }

 private:
  const Options& options_;
  clm::can::ProtocolConfig protocol_;
  std::vector<Cycle> cycles_;
};

std::int32_t position_raw(const Frame& f) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(f.data[0]) | (static_cast<std::uint32_t>(f.data[1]) << 8) |
                                   (static_cast<std::uint32_t>(f.data[2]) << 16) |
                                   (static_cast<std::uint32_t>(f.data[3]) << 24));
}

/// The speed the drive's positions show over cycles k−5 … k [m/s], NaN when a frame is missing.
double measured_velocity_m_per_s(const Bus& bus, int k) {
  const auto last = bus.frames(k, bus.drive_id());
  const auto first = bus.frames(k - 5, bus.drive_id());
  if (k < 6 || last.empty() || first.empty() || last.front()->frame.dlc != 7 || first.front()->frame.dlc != 7) return NAN;
  const double seconds = bus.cycle(k).sync_time_s - bus.cycle(k - 5).sync_time_s;
  return (static_cast<double>(position_raw(last.front()->frame)) - position_raw(first.front()->frame)) * 1e-9 / seconds;
}

// A push must change the speed by at least this, against the motion, within 10 cycles.
constexpr double kPushEvidence_m_per_s = 0.02;

/// The injected defect in cycle k.
bool defect_in_cycle(const Bus& bus, const std::string& kind, int k) {
  const auto drive = bus.frames(k, bus.drive_id());
  const auto previous = bus.frames(k - 1, bus.drive_id());
  if (kind == "drop-drive") return drive.empty();
  if (kind == "drop-force") return bus.frames(k, bus.force_id()).empty();
  if (kind == "corrupt-force-alive") {
    const auto force = bus.frames(k, bus.force_id());
    const auto before = bus.frames(k - 1, bus.force_id());
    return !force.empty() && !before.empty() && force.front()->frame.dlc == 8 && before.front()->frame.dlc == 8 &&
           static_cast<std::uint8_t>(force.front()->frame.data[7] - before.front()->frame.data[7]) != 1;
  }
  if (drive.empty()) return false;
  const Frame& f = drive.front()->frame;
  if (kind == "late-drive") {
    // Past the receive window, and after the daemon's setpoints of that cycle.
    const auto rpdo1 = bus.frames(k, bus.setpoint_id(0));
    return drive.front()->time_s - bus.cycle(k).sync_time_s >= bus.window_s() &&
           (rpdo1.empty() || rpdo1.front()->order < drive.front()->order);
  }
  if (kind == "corrupt-reserved") return f.dlc == 7 && ((f.data[4] | (f.data[5] << 8)) & clm::can::kStatusReservedMask) != 0;
  if (kind == "wrong-dlc") return f.dlc != 7;
  if (kind == "duplicate") return drive.size() == 2 && drive[0]->frame.data == drive[1]->frame.data;
  if (kind == "drive-fault") return f.dlc == 7 && (f.data[4] & clm::can::kStatusFault) != 0;
  if (previous.empty()) return false;
  const Frame& p = previous.front()->frame;
  if (kind == "corrupt-alive") return static_cast<std::uint8_t>(f.data[6] - p.data[6]) != 1;
  if (kind == "corrupt-position") return std::abs(static_cast<double>(position_raw(f)) - position_raw(p)) * 1e-9 > 0.1;
  return false;
}

void report_step(const Bus& bus, const std::map<std::string, std::string>& event) {
  const std::string kind = event.at("kind");
  const int n = std::atoi(event.at("sync").c_str());
  const int frames = std::atoi(event.at("frames").c_str());
  // Defects that act once (alive jump, fault bit) are checked in their first cycle.
  const int defect_cycles = (kind == "corrupt-alive" || kind == "corrupt-force-alive" || kind == "drive-fault") ? 1 : frames;
  bool seen = n >= 2 && n + defect_cycles - 1 <= bus.cycles();
  double push_change = NAN;  // the largest fall of the speed against the motion [m/s]
  if (kind == "push") {
    // The defect is in the motion, not in a frame: the speed before, and in
    // the push's first 10 cycles.
    const double before = measured_velocity_m_per_s(bus, n - 1);
    for (int k = n + 1; std::isfinite(before) && before != 0.0 && k < n + std::min(frames, 10) && k <= bus.cycles(); ++k) {
      const double change = (before - measured_velocity_m_per_s(bus, k)) * (before > 0.0 ? 1.0 : -1.0);
      if (std::isfinite(change) && !(change <= push_change)) push_change = change;
    }
    seen = push_change >= kPushEvidence_m_per_s;
  }
  for (int k = n; kind != "push" && seen && k < n + defect_cycles; ++k) seen = defect_in_cycle(bus, kind, k);
  if (kind == "drive-fault" && seen) seen = !defect_in_cycle(bus, kind, n - 1);
  double before_N = 0.0;
  for (int k = std::max(1, n - 20); k < n; ++k) before_N = std::max(before_N, bus.max_magnitude_N(k));
  std::printf("step=%s kind=%s frames=%d sync=%d seen_on_bus=%d enabled_before=%d max_setpoint_before_N=%.3f "
              "zero_after_cycles=%d enabled_after_cycles=%d%s\n",
              event.at("step").c_str(), kind.c_str(), frames, n, seen ? 1 : 0, bus.enabled(n - 1) == 1 ? 1 : 0, before_N,
              bus.first_zero_from(n), bus.enabled_run_from(n),
              kind == "push" ? (" speed_change_m_per_s=" + std::to_string(push_change)).c_str() : "");
}

void report_watchdog(const Bus& bus, const std::map<std::string, std::string>& event) {
  const int n = std::atoi(event.at("sync").c_str());  // the last SYNC before they stopped
  int next_status = -1;
  const auto drive = bus.frames(n + 1, bus.drive_id());
  if (!drive.empty() && drive.front()->frame.dlc == 7) {
    next_status = drive.front()->frame.data[4] | (drive.front()->frame.data[5] << 8);
  }
  const bool reports = next_status >= 0 && (next_status & clm::can::kStatusWatchdogExpired) != 0 &&
                       (next_status & clm::can::kStatusFault) != 0 && (next_status & clm::can::kStatusEnabled) == 0;
  const double gap_s = n + 1 <= bus.cycles() && n >= 1 ? bus.cycle(n + 1).sync_time_s - bus.cycle(n).sync_time_s : -1.0;
  std::printf("watchdog sync=%d last_enable=%d last_setpoint_N=%.3f sync_gap_s=%.3f next_feedback_reports_watchdog=%d "
              "after_last_setpoints_s=%s computed_after_last_setpoints_s=%s timeout_s=%s max_abs_current_A=%s\n",
              n, bus.enabled(n) == 1 ? 1 : 0, bus.max_magnitude_N(n), gap_s, reports ? 1 : 0,
              event.at("after_last_setpoints_s").c_str(), event.at("computed_after_last_setpoints_s").c_str(),
              event.at("timeout_s").c_str(),
              event.at("max_abs_current_A").c_str());
}

void report_flood(const Bus& bus, std::uint32_t id) {
  long count = 0;
  double first_s = 0.0, last_s = 0.0;
  int first_cycle = 0, last_cycle = 0;
  for (int k = 1; k <= bus.cycles(); ++k) {
    for (const TimedFrame* f : bus.frames(k, id)) {
      if (count == 0) first_s = f->time_s, first_cycle = k;
      last_s = f->time_s, last_cycle = k;
      ++count;
    }
  }
  int disabled = 0, missing_feedback = 0;
  for (int k = first_cycle; count > 0 && k <= last_cycle; ++k) {
    if (bus.enabled(k) != 1) ++disabled;
    if (bus.frames(k, bus.drive_id()).empty() || bus.frames(k, bus.force_id()).empty()) ++missing_feedback;
  }
  const double span_s = last_s - first_s;
  const double rate = span_s > 0.0 ? static_cast<double>(count - 1) / span_s : 0.0;
  // An 8-byte standard frame is at most 135 bits (docs/can-protocol.md, Bus load).
  std::printf("flood id=0x%03X frames=%ld span_s=%.3f rate_per_s=%.0f load_at_1Mbit_percent=%.1f cycles=%d "
              "cycles_not_enabled=%d cycles_missing_feedback_on_bus=%d\n",
              id, count, span_s, rate, rate * 135.0 / 1e6 * 100.0, count > 0 ? last_cycle - first_cycle + 1 : 0,
              disabled, missing_feedback);
}

void report_sim_killed(const Bus& bus) {
  int last = 0;
  for (int k = 1; k <= bus.cycles(); ++k) {
    if (!bus.frames(k, bus.drive_id()).empty() || !bus.frames(k, bus.force_id()).empty()) last = k;
  }
  const int n = last + 1;
  double before_N = 0.0;
  for (int k = std::max(1, n - 20); k < n; ++k) before_N = std::max(before_N, bus.max_magnitude_N(k));
  std::printf("sim-killed first_cycle_without_feedback=%d enabled_before=%d max_setpoint_before_N=%.3f "
              "zero_after_cycles=%d cycles_after=%d\n",
              n, bus.enabled(n - 1) == 1 ? 1 : 0, before_N, n <= bus.cycles() ? bus.first_zero_from(n) : 0,
              bus.cycles() - last);
}

/// What the bus shows of each injected fault in the log, per the options (main's work after parsing).
int report(const Options& options) {
  std::ifstream log(options.log_path);
  if (!log) throw std::runtime_error("cannot read " + options.log_path);
  std::vector<Cycle> cycles;
  std::string line;
  while (std::getline(log, line)) {
    TimedFrame timed;
    if (!parse_line(line, timed.time_s, timed.frame)) continue;
    if (timed.frame.id == clm::can::kSyncId) {
      cycles.push_back(Cycle{timed.time_s, {}});
      continue;
    }
    if (cycles.empty()) continue;
    timed.order = static_cast<int>(cycles.back().frames.size());
    cycles.back().frames.push_back(timed);
  }
  const Bus bus(options, std::move(cycles));
  std::printf("cycles=%d\n", bus.cycles());

  if (!options.events_path.empty()) {
    std::ifstream events(options.events_path);
    while (std::getline(events, line)) {
      const auto event = key_values(line);
      if (event.count("event") == 0 || event.count("sync") == 0) continue;
      if (event.at("event") == "inject") report_step(bus, event);
      if (event.at("event") == "watchdog") report_watchdog(bus, event);
    }
  }
  if (!options.flood_id.empty()) {
    report_flood(bus, static_cast<std::uint32_t>(std::strtoul(options.flood_id.c_str(), nullptr, 16)));
  }
  if (options.sim_killed) report_sim_killed(bus);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{"What the bus shows of each injected fault (docs/reliability.md)", "hil_fault_check"};
  app.add_option("--log", options.log_path, "candump -L log")->required()->check(CLI::ExistingFile);
  app.add_option("--events", options.events_path, "clm sim --event-log file")->check(CLI::ExistingFile);
  app.add_option("--coil-sets", options.coil_sets, "L")->check(clm::in_range(1, 4));
  app.add_option("--drive-node-id", options.drive_node_id)->check(clm::in_range(1, 127));
  app.add_option("--force-sensor-node-id", options.force_sensor_node_id)->check(clm::in_range(1, 127));
  app.add_option("--period-s", options.period_s, "cycle period [s]")->check(clm::positive_number());
  app.add_option("--receive-window-fraction", options.receive_window_fraction)->check(clm::in_range(0.05, 0.9));
  app.add_option("--flood-id", options.flood_id, "identifier of the flood frames, hex");
  app.add_flag("--sim-killed", options.sim_killed, "report the cycles from the feedback's end to zero setpoints");
  // The programs' convention (config/command_line.hpp): 2 and one line on a bad command line.
  return clm::run_command_line(app, argc, argv, [&] { return report(options); });
}
