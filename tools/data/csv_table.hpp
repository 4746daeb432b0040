#pragma once
// CSV files of the tools (docs/data-formats.md): a header row, columns found
// by name, extra columns ignored. Errors name the file, the row (the file's
// line number) and the column.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace clm::data {

/// How much a data file may hold (docs/data-formats.md, "Size limits"): the
/// defaults keep `clm identify` within its documented memory budget; the
/// tools' --max-bytes and --max-rows raise them.
struct DataLimits {
  static constexpr std::uint64_t kDefaultMaxBytes = std::uint64_t{2} << 30;  ///< 2 GiB
  static constexpr std::size_t kDefaultMaxRows = 10'000'000;
  std::uint64_t max_bytes = kDefaultMaxBytes;  ///< of the file
  std::size_t max_rows = kDefaultMaxRows;      ///< data rows (CSV) or CLM_SERVO_STATE messages (LCM log)
};

class CsvTable {
 public:
  /// Reads the whole of a regular file (clm::read_regular_file: a FIFO, a
  /// device or a directory is refused without blocking) of at most
  /// limits.max_bytes, then parse; throws std::runtime_error with one line
  /// naming the file.
  static CsvTable load(const std::string& path, const DataLimits& limits = {});
  /// Splits `text` into rows; throws std::runtime_error on an empty text, a
  /// column name that appears twice in the header (line 1), a row with a
  /// different number of cells than the header, a blank line inside the data,
  /// or more than `max_rows` data rows.
  static CsvTable parse(std::string text, const std::string& origin,
                        std::size_t max_rows = DataLimits::kDefaultMaxRows);
  /// A table whose numbers come from elsewhere than CSV text (an LCM log
  /// converted by clm::lcmlog): `values[column][row]`, one name per column,
  /// columns of equal length. Rows are named in errors as
  /// "<origin>: <row_word> <row_numbers[row]>" (e.g. "run.lcm: event 1742"),
  /// or "<origin>: row <row + 1>" without row numbers. The numbers are used
  /// exactly as given: no text round trip. Throws std::invalid_argument on
  /// mismatched lengths or a name given twice.
  static CsvTable from_columns(std::string origin, std::vector<std::string> names,
                               std::vector<std::vector<double>> values, std::string row_word = "row",
                               std::vector<std::int64_t> row_numbers = {});

  const std::string& origin() const { return origin_; }
  std::size_t rows() const { return rows_; }
  bool has(std::string_view column) const;
  /// Values of a column, every one a finite number; throws naming file, row and
  /// column for a missing column, a non-number, NaN or infinity.
  std::vector<double> numbers(std::string_view column) const;
  /// Line number in the file of data row `row` (0-based); CSV text only.
  std::size_t line_of(std::size_t row) const { return row + 2; }
  /// Where data row `row` (0-based) is, for an error message: "data.csv:17"
  /// (the file's line) or, for a table from_columns, "run.lcm: event 1742".
  std::string where(std::size_t row) const;
  /// Where the column names are: "data.csv:1", or the origin alone.
  std::string where_header() const;

 private:
  std::string origin_;
  std::shared_ptr<std::string> text_;
  std::vector<std::string_view> header_;
  std::vector<std::size_t> row_starts_;  // offset in text_ of each data row's line
  std::size_t rows_ = 0;
  // from_columns only: the numbers themselves and how rows are named.
  bool numeric_ = false;
  std::vector<std::string> names_;
  std::vector<std::vector<double>> values_;
  std::string row_word_;
  std::vector<std::int64_t> row_numbers_;
};

/// Writes a CSV atomically; `columns` and `values[column][row]` have equal lengths.
void write_csv_atomically(const std::string& path, std::span<const std::string> columns,
                          std::span<const std::vector<double>> values);

/// Shortest text that reads back as the same double.
std::string shortest_double(double value);

}  // namespace clm::data
