#pragma once
// CSV files of the tools (docs/data-formats.md): a header row, columns found
// by name, extra columns ignored. Errors name the file, the row (the file's
// line number) and the column.

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace clm {

class CsvTable {
 public:
  /// Reads and splits the whole file; throws std::runtime_error on I/O errors,
  /// an empty file or a row with a different number of cells than the header.
  static CsvTable load(const std::string& path);
  static CsvTable parse(std::string text, const std::string& origin);

  const std::string& origin() const { return origin_; }
  std::size_t rows() const { return rows_; }
  bool has(std::string_view column) const;
  /// Values of a column, every one a finite number; throws naming file, row and
  /// column for a missing column, a non-number, NaN or infinity.
  std::vector<double> numbers(std::string_view column) const;
  /// Line number in the file of data row `row` (0-based).
  std::size_t line_of(std::size_t row) const { return row + 2; }

 private:
  std::string origin_;
  std::shared_ptr<std::string> text_;
  std::vector<std::string_view> header_;
  std::vector<std::string_view> cells_;  // row-major
  std::size_t rows_ = 0;
};

/// Writes a CSV atomically; `columns` and `values[column][row]` have equal lengths.
void write_csv_atomically(const std::string& path, std::span<const std::string> columns,
                          std::span<const std::vector<double>> values);

/// Shortest text that reads back as the same double.
std::string shortest_double(double value);

}  // namespace clm
