// hil_candump_check: every frame of a candump log (`candump -L`) must decode
// against drivers/can/clm-servo.dbc (or, with --drive-profile phase_current,
// clm-servo-phase-current.dbc) and through the codec (drivers/can_protocol.hpp).
//
// For each line: the identifier must be a DBC message, the DLC the DBC's, every
// signal's raw value inside the DBC's [minimum, maximum], every bit no signal
// covers zero, and the codec's decoder for that frame must return kOk (which
// also checks reserved bits, the SYNC counter range and, for RPDO2 at L = 2,
// the unused coil-set fields). Anything else on a line (error frames,
// extended or remote frames, CAN FD, candump's DROPCOUNT lines, text that is
// not a frame) is a failure, reported with its line number.
//
// Also counts the frames per message and, for information, the gaps in the
// SYNC counter and the alive counters (lost frames would show there), and in
// the drive latch frames' (0x280 + drive node) latch count when there are any.
//
// Exit status: 0 every frame decodes (and there are at least --min-frames);
// 1 a frame does not decode or too few frames; 2 bad arguments, unreadable files.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/command_line.hpp"
#include "drivers/can/can_protocol.hpp"
#include "drivers/dbc.hpp"

namespace {

using clm::can::CodecStatus;
using clm::can::Frame;

struct Options {
  std::string dbc_path;
  std::string log_path;
  int coil_sets = 3;
  int drive_node_id = 1;
  int force_sensor_node_id = 2;
  std::string drive_profile = "magnitude_phase";
  long long min_frames = 1;
  int max_reports = 20;
};

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

/// Parses the frame of one `candump -L` line, "(1700000000.123456) vcan0 181#15CD5B0711002A".
/// Returns an empty string and fills `frame`, or the reason the line is not a
/// classic standard data frame.
std::string parse_line(const std::string& line, Frame& frame) {
  if (line.rfind("DROPCOUNT", 0) == 0) return "candump lost frames";
  if (line.empty() || line[0] != '(') return "not a candump -L frame line";
  const auto close = line.find(") ");
  if (close == std::string::npos) return "no ') ' after the timestamp";
  const auto space = line.find(' ', close + 2);
  if (space == std::string::npos) return "no frame after the interface name";
  const std::string text = line.substr(space + 1);
  const auto hash = text.find('#');
  if (hash == std::string::npos) return "no '#' in the frame";
  const std::string id_text = text.substr(0, hash);
  const std::string data_text = text.substr(hash + 1);
  if (id_text.size() == 8) {
    std::uint32_t id = 0;
    for (char c : id_text) id = id * 16 + static_cast<std::uint32_t>(std::max(hex_digit(c), 0));
    return (id & 0x20000000u) != 0 ? "error frame (CAN_ERR_FLAG)" : "extended (29-bit) identifier";
  }
  if (id_text.size() != 3) return "identifier '" + id_text + "' is not 3 hex digits";
  std::uint32_t id = 0;
  for (char c : id_text) {
    const int digit = hex_digit(c);
    if (digit < 0) return "identifier '" + id_text + "' is not hex";
    id = id * 16 + static_cast<std::uint32_t>(digit);
  }
  if (!data_text.empty() && data_text[0] == '#') return "CAN FD frame";
  if (!data_text.empty() && (data_text[0] == 'R' || data_text[0] == 'r')) return "remote frame";
  if (data_text.size() % 2 != 0 || data_text.size() > 16) return "data '" + data_text + "' is not 0..8 hex bytes";
  frame = Frame{};
  frame.id = id;
  frame.dlc = static_cast<std::uint8_t>(data_text.size() / 2);
  for (std::size_t k = 0; k < frame.dlc; ++k) {
    const int high = hex_digit(data_text[2 * k]), low = hex_digit(data_text[2 * k + 1]);
    if (high < 0 || low < 0) return "data '" + data_text + "' is not hex";
    frame.data[k] = static_cast<std::uint8_t>(high * 16 + low);
  }
  return "";
}

/// The codec's decoder for the frame's identifier; kWrongId if none.
CodecStatus decode_with_codec(const clm::can::ProtocolConfig& config, const Frame& frame) {
  if (frame.id == clm::can::kSyncId) {
    std::uint8_t counter = 0;
    return clm::can::decode_sync(frame, counter);
  }
  if (frame.id == clm::can::drive_feedback_id(config)) {
    clm::can::DriveFeedback feedback;
    return clm::can::decode_drive_feedback(config, frame, feedback);
  }
  if (frame.id == clm::can::drive_latch_id(config)) {
    clm::can::DriveLatch latch;
    return clm::can::decode_drive_latch(config, frame, latch);
  }
  if (clm::can::has_force_sensor(config) && frame.id == clm::can::force_feedback_id(config)) {
    clm::can::ForceFeedback feedback;
    return clm::can::decode_force_feedback(config, frame, feedback);
  }
  clm::can::SetpointCommand accumulate;
  return clm::can::decode_setpoint_frame(config, frame, accumulate);
}

/// Counts jumps other than +1 (mod `modulus`, from `first`) in a counter.
struct CounterGaps {
  std::optional<int> last;
  long long gaps = 0;
  void see(int value, int first, int last_value) {
    if (last) {
      const int expected = *last >= last_value ? first : *last + 1;
      if (value != expected) ++gaps;
    }
    last = value;
  }
};

int check(const Options& options) {
  const clm::test::DbcFile dbc = clm::test::read_dbc(options.dbc_path);
  clm::can::ProtocolConfig config;
  config.coil_sets = options.coil_sets;
  config.drive_node_id = static_cast<std::uint8_t>(options.drive_node_id);
  config.force_sensor_node_id = static_cast<std::uint8_t>(options.force_sensor_node_id);
  config.drive_profile = options.drive_profile == "phase_current" ? clm::DriveProfile::kPhaseCurrent
                                                                  : clm::DriveProfile::kMagnitudePhase;
  config.validate();

  std::ifstream input(options.log_path);
  if (!input) throw std::runtime_error(options.log_path + ": cannot open");

  std::map<std::uint32_t, const clm::test::DbcMessage*> messages;
  for (const auto& message : dbc.messages) messages[message.id] = &message;

  std::map<std::string, long long> per_message;
  std::map<std::uint32_t, CounterGaps> alive_gaps;
  CounterGaps sync_gaps;
  CounterGaps latch_gaps;  // the drive latch's count: +1 per latch, so a gap is a lost latch frame
  long long latch_frames = 0;
  long long frames = 0, bad = 0, line_number = 0;
  std::string line;
  const auto report = [&](const std::string& reason) {
    ++bad;
    if (bad <= options.max_reports) {
      std::printf("%s:%lld: %s: %s\n", options.log_path.c_str(), line_number, reason.c_str(), line.c_str());
    }
  };
  while (std::getline(input, line)) {
    ++line_number;
    if (line.empty()) continue;
    Frame frame;
    if (const std::string problem = parse_line(line, frame); !problem.empty()) {
      report(problem);
      continue;
    }
    ++frames;
    const auto found = messages.find(frame.id);
    if (found == messages.end()) {
      char id_text[16];
      std::snprintf(id_text, sizeof id_text, "0x%03X", static_cast<unsigned>(frame.id));
      report(std::string("no message with identifier ") + id_text + " in the DBC");
      continue;
    }
    const clm::test::DbcMessage& message = *found->second;
    if (frame.dlc != message.dlc) {
      report(message.name + ": DLC " + std::to_string(frame.dlc) + ", the DBC says " + std::to_string(message.dlc));
      continue;
    }
    std::string problem;
    std::uint64_t covered = 0;
    for (const auto& signal : message.signals) {
      const std::int64_t raw = clm::test::extract_raw(signal, frame);
      if (raw < signal.raw_minimum() || raw > signal.raw_maximum()) {
        problem = message.name + "." + signal.name + ": raw " + std::to_string(raw) + " outside the DBC's [" +
                  std::to_string(signal.raw_minimum()) + ", " + std::to_string(signal.raw_maximum()) + "]";
        break;
      }
      for (int bit = signal.start_bit; bit < signal.start_bit + signal.length_bits; ++bit) covered |= 1ull << bit;
    }
    if (problem.empty()) {
      std::uint64_t payload = 0;
      for (std::size_t k = 0; k < frame.dlc; ++k) payload |= static_cast<std::uint64_t>(frame.data[k]) << (8 * k);
      if ((payload & ~covered) != 0) problem = message.name + ": bits set that no DBC signal covers";
    }
    if (problem.empty()) {
      const CodecStatus status = decode_with_codec(config, frame);
      if (status != CodecStatus::kOk) problem = message.name + ": the codec refuses it (" + clm::can::to_string(status) + ")";
    }
    if (!problem.empty()) {
      report(problem);
      continue;
    }
    ++per_message[message.name];
    if (frame.id == clm::can::kSyncId) {
      sync_gaps.see(frame.data[0], clm::can::kSyncCounterFirst, clm::can::kSyncCounterLast);
    } else if (frame.id == clm::can::drive_latch_id(config)) {
      ++latch_frames;
      latch_gaps.see(frame.data[4], 0, 255);  // byte 4: the latch count
    } else {
      // The alive counter's byte: drive feedback 6, force feedback 7, RPDO1 1 (RPDO2/3 have none).
      int alive_byte = -1;
      if (frame.id == clm::can::drive_feedback_id(config)) alive_byte = 6;
      if (clm::can::has_force_sensor(config) && frame.id == clm::can::force_feedback_id(config)) alive_byte = 7;
      if (frame.id == clm::can::setpoint_id(config, 0)) alive_byte = 1;
      if (alive_byte >= 0) alive_gaps[frame.id].see(frame.data[static_cast<std::size_t>(alive_byte)], 0, 255);
    }
  }

  std::string counts;
  for (const auto& [name, count] : per_message) counts += (counts.empty() ? "" : ", ") + name + " " + std::to_string(count);
  std::string gaps = "SYNC counter " + std::to_string(sync_gaps.gaps);
  for (const auto& [id, g] : alive_gaps) {
    char text[48];
    std::snprintf(text, sizeof text, ", alive 0x%03X %lld", static_cast<unsigned>(id), g.gaps);
    gaps += text;
  }
  if (latch_frames > 0) gaps += ", latch count " + std::to_string(latch_gaps.gaps);
  if (bad > options.max_reports) std::printf("... and %lld more\n", bad - options.max_reports);
  if (bad > 0) {
    std::printf("hil_candump_check: FAIL: %lld of %lld lines of %s do not decode against %s (%s)\n", bad,
                line_number, options.log_path.c_str(), options.dbc_path.c_str(), counts.c_str());
    return 1;
  }
  if (frames < options.min_frames) {
    std::printf("hil_candump_check: FAIL: %lld frames in %s, expected at least %lld\n", frames,
                options.log_path.c_str(), options.min_frames);
    return 1;
  }
  std::printf("hil_candump_check: all %lld frames of %s decode against %s: %s; counter gaps: %s\n", frames,
              options.log_path.c_str(), options.dbc_path.c_str(), counts.c_str(), gaps.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hil_candump_check: every frame of a candump -L log must decode against the DBC and the codec",
               "hil_candump_check"};
  Options options;
  app.add_option("--dbc", options.dbc_path, "DBC file (drivers/can/clm-servo.dbc)")->required()->check(CLI::ExistingFile);
  app.add_option("--log", options.log_path, "candump -L output")->required()->check(CLI::ExistingFile);
  app.add_option("--drive-profile", options.drive_profile,
                 "what the setpoint RPDOs carry (drive.profile): magnitude_phase with clm-servo.dbc, phase_current "
                 "with clm-servo-phase-current.dbc")
      ->check(CLI::IsMember({"magnitude_phase", "phase_current"}))
      ->capture_default_str();
  app.add_option("--coil-sets", options.coil_sets, "L of the motor on the bus")->check(clm::in_range(1, 4))->capture_default_str();
  app.add_option("--drive-node-id", options.drive_node_id, "drive node ID")->check(clm::in_range(1, 127))->capture_default_str();
  app.add_option("--force-sensor-node-id", options.force_sensor_node_id,
                 "force sensor node ID; 0: the axis has none, and a force frame on the bus does not decode")
      ->check(clm::in_range(0, 127))
      ->capture_default_str();
  app.add_option("--min-frames", options.min_frames, "fail with fewer frames than this")->capture_default_str();
  app.add_option("--max-reports", options.max_reports, "undecodable lines printed at most")->capture_default_str();
  // The programs' convention (config/command_line.hpp): 2 and one line on bad usage or input, check()'s 0 or 1.
  return clm::run_command_line(app, argc, argv, [&] { return check(options); });
}
