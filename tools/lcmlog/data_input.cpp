#include "tools/lcmlog/data_input.hpp"

#include <sys/stat.h>

#include <array>
#include <cstdint>
#include <cstdio>
#include <stdexcept>

#include "config/command_line.hpp"
#include "config/exit_status.hpp"
#include "config/regular_file.hpp"

namespace clm::lcmlog {

bool is_lcm_log(const std::string& path) {
  // Only a regular file is opened (a FIFO without a writer would block here);
  // its size is checked by the reader that follows.
  RegularFile file = open_regular_file(path, kUnlimitedBytes);
  std::array<unsigned char, 4> magic{};
  if (file.read(magic.data(), magic.size()) != magic.size()) return false;
  // 0xEDA1DA01 big-endian; no CSV header starts with these bytes (not UTF-8 text).
  return magic == std::array<unsigned char, 4>{0xED, 0xA1, 0xDA, 0x01};
}

void add_gap_option(CLI::App& subcommand, GapPolicy& policy) {
  policy.subcommand = subcommand.get_name();
  subcommand.add_flag("--fail-on-gaps", policy.fail_on_gaps,
                      "refuse an LCM log with CLM_SERVO_STATE messages missing (a gap in the cycle counter) or "
                      "telemetry the daemon dropped (exit status 1); without it they are a warning");
}

void report_gaps(const std::string& lcm_log_path, const LogGaps& gaps, const GapPolicy& policy) {
  const std::string line = describe_gaps(lcm_log_path, gaps);
  if (line.empty()) return;
  const std::string name = policy.subcommand.empty() ? "clm" : "clm " + policy.subcommand;
  if (!policy.fail_on_gaps) {
    std::fprintf(stderr, "%s: warning: %s\n", name.c_str(), line.c_str());
    return;
  }
  // A run-time failure (exit 1); the program prints the one line with its prefix.
  throw RunTimeFailure(line + " (--fail-on-gaps)");
}

data::CsvTable load_data_table(const std::string& path, CsvFormat format, const data::DataLimits& limits,
                               const GapPolicy& gaps) {
  if (!is_lcm_log(path)) return data::CsvTable::load(path, limits);
  ServoStateLog log = read_servo_state_log(path, limits);
  report_gaps(path, log.gaps, gaps);
  CsvColumns columns;
  try {
    columns = to_csv_columns(log.states, format);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  std::vector<std::int64_t> events(columns.rows());
  for (std::size_t r = 0; r < events.size(); ++r) events[r] = log.events[columns.source_states[r]];
  return data::CsvTable::from_columns(path, std::move(columns.names), std::move(columns.values), "event",
                                      std::move(events));
}

CLI::Validator existing_input_file() {
  return CLI::Validator(
      [](std::string& path) {
        struct stat status {};
        if (::stat(path.c_str(), &status) != 0) return "File does not exist: " + path;
        return std::string();
      },
      "FILE");
}

void add_data_limit_options(CLI::App& subcommand, data::DataLimits& limits, const std::string& file_option) {
  subcommand
      .add_option("--max-bytes", limits.max_bytes,
                  "refuse a " + file_option + " file of more bytes than this (docs/data-formats.md, size limits)")
      ->check(clm::positive_number())
      ->capture_default_str();
  subcommand
      .add_option("--max-rows", limits.max_rows,
                  "refuse a " + file_option + " file of more data rows (or CLM_SERVO_STATE messages) than this")
      ->check(clm::positive_number())
      ->capture_default_str();
}

}  // namespace clm::lcmlog
