#include "tools/data/csv_table.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <unordered_map>

#include "config/atomic_file.hpp"
#include "config/regular_file.hpp"

namespace clm::data {
namespace {

std::string_view trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r')) text.remove_suffix(1);
  return text;
}

void split_line(std::string_view line, std::vector<std::string_view>& out) {
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    out.push_back(trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
}

/// Throws "<where>: column 'Fy_N' appears twice (columns 6 and 9)" for the
/// first name that repeats an earlier one (columns counted from 1).
void check_unique_names(const std::vector<std::string_view>& names, const std::string& where) {
  std::unordered_map<std::string_view, std::size_t> seen;
  seen.reserve(names.size());
  for (std::size_t c = 0; c < names.size(); ++c) {
    const auto [at, inserted] = seen.emplace(names[c], c);
    if (!inserted) {
      throw std::runtime_error(where + ": column '" + std::string(names[c]) + "' appears twice (columns " +
                               std::to_string(at->second + 1) + " and " + std::to_string(c + 1) + ")");
    }
  }
}

/// Cell `index` (0-based) of the line starting at `line_start`: the text
/// between the index-th and the next comma, trimmed (as split_line would
/// give it; parse checked that the line has the header's cell count).
std::string_view cell_of(std::string_view all, std::size_t line_start, std::size_t index) {
  std::size_t line_end = all.find('\n', line_start);
  if (line_end == std::string_view::npos) line_end = all.size();
  std::size_t from = line_start;
  for (std::size_t k = 0; k < index; ++k) from = all.find(',', from) + 1;
  std::size_t to = all.find(',', from);
  if (to == std::string_view::npos || to > line_end) to = line_end;
  return trim(all.substr(from, to - from));
}

}  // namespace

CsvTable CsvTable::load(const std::string& path, const DataLimits& limits) {
  std::string text = read_regular_file(path, limits.max_bytes, " for a data file (--max-bytes raises it)");
  return parse(std::move(text), path, limits.max_rows);
}

CsvTable CsvTable::parse(std::string text, const std::string& origin, std::size_t max_rows) {
  CsvTable table;
  table.origin_ = origin;
  table.text_ = std::make_shared<std::string>(std::move(text));
  const std::string_view all(*table.text_);
  // Rows are kept as the offsets where their lines start (8 bytes a row); a
  // column's cells are found again when numbers() asks for it. One count of
  // the lines first, so that the offsets are allocated once.
  const std::size_t lines = static_cast<std::size_t>(std::count(all.begin(), all.end(), '\n')) + 1;
  table.row_starts_.reserve(std::min(lines - 1, max_rows));
  std::size_t start = 0;
  std::size_t line_number = 0;
  while (start < all.size()) {
    std::size_t end = all.find('\n', start);
    if (end == std::string_view::npos) end = all.size();
    const std::size_t line_start = start;
    const std::string_view line = trim(all.substr(start, end - start));
    start = end + 1;
    ++line_number;
    if (line.empty()) continue;
    if (table.header_.empty()) {
      split_line(line, table.header_);
      check_unique_names(table.header_, origin + ":" + std::to_string(line_number));
      continue;
    }
    const std::size_t cell_count = 1 + static_cast<std::size_t>(std::count(line.begin(), line.end(), ','));
    if (cell_count != table.header_.size()) {
      throw std::runtime_error(origin + ":" + std::to_string(line_number) + ": " + std::to_string(cell_count) +
                               " cells, the header has " + std::to_string(table.header_.size()));
    }
    if (table.rows_ == max_rows) {
      throw std::runtime_error(origin + ":" + std::to_string(line_number) + ": more than " +
                               std::to_string(max_rows) + " data rows, the limit (--max-rows raises it)");
    }
    table.row_starts_.push_back(line_start);
    ++table.rows_;
    if (line_number != table.rows_ + 1) {
      // Blank lines inside the data would make row numbers lie; refuse them.
      throw std::runtime_error(origin + ":" + std::to_string(line_number) + ": blank line inside the data");
    }
  }
  if (table.header_.empty()) throw std::runtime_error(origin + ": empty file, expected a header row");
  return table;
}

CsvTable CsvTable::from_columns(std::string origin, std::vector<std::string> names,
                                std::vector<std::vector<double>> values, std::string row_word,
                                std::vector<std::int64_t> row_numbers) {
  if (names.size() != values.size()) throw std::invalid_argument("CsvTable: column names and value columns differ");
  CsvTable table;
  table.numeric_ = true;
  table.origin_ = std::move(origin);
  table.rows_ = values.empty() ? 0 : values.front().size();
  for (const auto& column : values) {
    if (column.size() != table.rows_) throw std::invalid_argument("CsvTable: columns of different lengths");
  }
  if (!row_numbers.empty() && row_numbers.size() != table.rows_) {
    throw std::invalid_argument("CsvTable: row numbers and rows differ");
  }
  {
    const std::vector<std::string_view> views(names.begin(), names.end());
    try {
      check_unique_names(views, table.origin_);
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument(std::string("CsvTable: ") + e.what());
    }
  }
  table.names_ = std::move(names);
  table.values_ = std::move(values);
  table.row_word_ = std::move(row_word);
  table.row_numbers_ = std::move(row_numbers);
  return table;
}

std::string CsvTable::where(std::size_t row) const {
  if (!numeric_) return origin_ + ":" + std::to_string(line_of(row));
  const std::int64_t number = row_numbers_.empty() ? static_cast<std::int64_t>(row + 1) : row_numbers_[row];
  return origin_ + ": " + row_word_ + " " + std::to_string(number);
}

std::string CsvTable::where_header() const { return numeric_ ? origin_ : origin_ + ":1"; }

bool CsvTable::has(std::string_view column) const {
  if (numeric_) {
    for (const auto& name : names_) {
      if (name == column) return true;
    }
    return false;
  }
  for (auto name : header_) {
    if (name == column) return true;
  }
  return false;
}

std::vector<double> CsvTable::numbers(std::string_view column) const {
  const auto missing = [&] {
    return std::runtime_error(where_header() + ": missing column '" + std::string(column) + "'");
  };
  if (numeric_) {
    for (std::size_t c = 0; c < names_.size(); ++c) {
      if (names_[c] != column) continue;
      for (std::size_t r = 0; r < rows_; ++r) {
        if (!std::isfinite(values_[c][r])) {
          throw std::runtime_error(where(r) + ": column '" + std::string(column) + "': '" +
                                   shortest_double(values_[c][r]) + "' is not a finite number");
        }
      }
      return values_[c];
    }
    throw missing();
  }
  std::size_t index = header_.size();
  for (std::size_t c = 0; c < header_.size(); ++c) {
    if (header_[c] == column) index = c;
  }
  if (index == header_.size()) throw missing();
  std::vector<double> values(rows_);
  for (std::size_t r = 0; r < rows_; ++r) {
    const std::string_view cell = cell_of(*text_, row_starts_[r], index);
    double value = 0.0;
    const auto result = std::from_chars(cell.data(), cell.data() + cell.size(), value);
    if (cell.empty() || result.ec != std::errc() || result.ptr != cell.data() + cell.size() || !std::isfinite(value)) {
      throw std::runtime_error(where(r) + ": column '" + std::string(column) + "': '" + std::string(cell) +
                               "' is not a finite number");
    }
    values[r] = value;
  }
  return values;
}

std::string shortest_double(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

void write_csv_atomically(const std::string& path, std::span<const std::string> columns,
                          std::span<const std::vector<double>> values) {
  if (columns.size() != values.size()) throw std::invalid_argument("CSV: column names and value columns differ");
  const std::size_t rows = values.empty() ? 0 : values[0].size();
  std::string out;
  out.reserve(rows * columns.size() * 12 + 256);
  for (std::size_t c = 0; c < columns.size(); ++c) {
    if (c > 0) out += ',';
    out += columns[c];
  }
  out += '\n';
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (c > 0) out += ',';
      out += shortest_double(values[c][r]);
    }
    out += '\n';
  }
  write_file_atomically(path, out);
}

}  // namespace clm::data
