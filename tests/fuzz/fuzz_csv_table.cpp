// libFuzzer harness: the CSV reader, tools/data/csv_table.hpp CsvTable::parse
// and numbers() on every header column.
//
// Refusal: std::runtime_error (the header's promise). Invariants: numbers()
// gives rows() finite values, where() names a line of the text.

#include <cmath>
#include <optional>
#include <stdexcept>

#include "fuzz_support.hpp"
#include "tools/data/csv_table.hpp"

using clm::fuzz::require;

namespace {

/// Leading blanks and tabs, trailing blanks, tabs and carriage returns removed.
std::string trim(std::string text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return std::string();
  text.erase(0, first);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r')) text.pop_back();
  return text;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = clm::fuzz::as_text(data, size);
  std::optional<clm::data::CsvTable> table;
  try {
    table.emplace(clm::data::CsvTable::parse(text, "fuzz.csv"));
  } catch (const std::runtime_error&) {
    return 0;
  }
  // The header's names as the reader's documentation defines them: the first
  // line that is not blank, split at commas, each cell trimmed.
  std::vector<std::string> names;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    const std::string line = trim(text.substr(start, end - start));
    start = end + 1;
    if (line.empty()) continue;
    std::size_t from = 0;
    while (true) {
      const std::size_t comma = line.find(',', from);
      names.push_back(trim(line.substr(from, comma == std::string::npos ? std::string::npos : comma - from)));
      if (comma == std::string::npos) break;
      from = comma + 1;
    }
    break;
  }
  require(!names.empty(), "parse accepted a text without a header");
  for (const auto& name : names) {
    require(table->has(name), "a header column is missing", name);
    try {
      const auto values = table->numbers(name);
      require(values.size() == table->rows(), "numbers() gave another count than rows()", name);
      for (double value : values) require(std::isfinite(value), "numbers() gave a non-finite value", name);
    } catch (const std::runtime_error&) {
    }
  }
  if (table->rows() > 0) {
    require(table->where(table->rows() - 1).rfind("fuzz.csv:", 0) == 0, "where() does not name the file");
  }
  if (!table->has("no such column")) {
    try {
      table->numbers("no such column");
      require(false, "numbers() accepted a missing column");
    } catch (const std::runtime_error&) {
    }
  }
  return 0;
}
