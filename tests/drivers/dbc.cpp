#include "dbc.hpp"

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>

namespace clm::test {
namespace {

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream stream(text);
  while (std::getline(stream, part, separator)) {
    if (!part.empty()) parts.push_back(part);
  }
  return parts;
}

}  // namespace

std::int64_t DbcSignal::raw_minimum() const { return std::llround((minimum - offset) / scale); }
std::int64_t DbcSignal::raw_maximum() const { return std::llround((maximum - offset) / scale); }

DbcFile read_dbc(const std::string& path) {
  std::ifstream input(path);
  if (!input) throw std::runtime_error(path + ": cannot open");
  // BO_ <id> <name>: <dlc> <sender>
  const std::regex message_line(R"(^BO_\s+(\d+)\s+(\w+)\s*:\s*(\d+)\s+(\w+)\s*$)");
  // SG_ <name> : <start>|<length>@<order><sign> (<scale>,<offset>) [<min>|<max>] "<unit>" <receivers>
  const std::regex signal_line(
      R"re(^\s+SG_\s+(\w+)\s*:\s*(\d+)\|(\d+)@([01])([+-])\s*\(([^,]+),([^)]+)\)\s*\[([^|]+)\|([^\]]+)\]\s*"([^"]*)"\s+(\S+)\s*$)re");
  DbcFile file;
  std::string line;
  int line_number = 0;
  while (std::getline(input, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto where = [&] { return path + ":" + std::to_string(line_number) + ": "; };
    std::smatch match;
    if (line.rfind("BU_:", 0) == 0) {
      std::istringstream names(line.substr(4));
      for (std::string node; names >> node;) file.nodes.push_back(node);
    } else if (line.rfind("BO_ ", 0) == 0) {
      if (!std::regex_match(line, match, message_line)) throw std::runtime_error(where() + "malformed BO_ line");
      DbcMessage message;
      message.id = static_cast<std::uint32_t>(std::stoul(match[1]));
      message.name = match[2];
      message.dlc = std::stoi(match[3]);
      message.sender = match[4];
      file.messages.push_back(message);
    } else if (line.find("SG_ ") != std::string::npos && line.rfind(" SG_", 0) == 0) {
      if (!std::regex_match(line, match, signal_line)) throw std::runtime_error(where() + "malformed SG_ line");
      if (file.messages.empty()) throw std::runtime_error(where() + "SG_ before any BO_");
      DbcSignal signal;
      signal.name = match[1];
      signal.start_bit = std::stoi(match[2]);
      signal.length_bits = std::stoi(match[3]);
      signal.little_endian = match[4] == "1";
      signal.is_signed = match[5] == "-";
      signal.scale = std::stod(match[6]);
      signal.offset = std::stod(match[7]);
      signal.minimum = std::stod(match[8]);
      signal.maximum = std::stod(match[9]);
      signal.unit = match[10];
      signal.receivers = split(match[11], ',');
      file.messages.back().signals.push_back(signal);
    }
  }
  return file;
}

std::int64_t extract_raw(const DbcSignal& signal, const clm::can::Frame& frame) {
  std::uint64_t bits = 0;
  for (int i = 0; i < signal.length_bits; ++i) {
    const int bit = signal.start_bit + i;
    const std::uint64_t value = (frame.data[static_cast<std::size_t>(bit / 8)] >> (bit % 8)) & 1u;
    bits |= value << i;
  }
  if (signal.is_signed && ((bits >> (signal.length_bits - 1)) & 1u) != 0) {
    return static_cast<std::int64_t>(bits) - (std::int64_t{1} << signal.length_bits);
  }
  return static_cast<std::int64_t>(bits);
}

void insert_raw(const DbcSignal& signal, std::int64_t raw, clm::can::Frame& frame) {
  const auto bits = static_cast<std::uint64_t>(raw);
  for (int i = 0; i < signal.length_bits; ++i) {
    const int bit = signal.start_bit + i;
    auto& byte = frame.data[static_cast<std::size_t>(bit / 8)];
    const auto mask = static_cast<std::uint8_t>(1u << (bit % 8));
    if (((bits >> i) & 1u) != 0) {
      byte = static_cast<std::uint8_t>(byte | mask);
    } else {
      byte = static_cast<std::uint8_t>(byte & ~mask);
    }
  }
}

}  // namespace clm::test
