#include "tools/lcmlog/data_input.hpp"

#include <sys/stat.h>

#include <array>
#include <cstdint>
#include <stdexcept>

#include "config/command_line.hpp"
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

data::CsvTable load_data_table(const std::string& path, CsvFormat format, const data::DataLimits& limits) {
  if (!is_lcm_log(path)) return data::CsvTable::load(path, limits);
  ServoStateLog log = read_servo_state_log(path, limits);
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
