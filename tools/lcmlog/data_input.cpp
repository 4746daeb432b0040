#include "tools/lcmlog/data_input.hpp"

#include <array>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace clm::lcmlog {

bool is_lcm_log(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open: " + std::strerror(errno));
  std::array<unsigned char, 4> magic{};
  in.read(reinterpret_cast<char*>(magic.data()), magic.size());
  if (in.gcount() != static_cast<std::streamsize>(magic.size())) return false;
  // 0xEDA1DA01 big-endian; no CSV header starts with these bytes (not UTF-8 text).
  return magic == std::array<unsigned char, 4>{0xED, 0xA1, 0xDA, 0x01};
}

data::CsvTable load_data_table(const std::string& path, CsvFormat format) {
  if (!is_lcm_log(path)) return data::CsvTable::load(path);
  ServoStateLog log = read_servo_state_log(path);
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

}  // namespace clm::lcmlog
