#pragma once
// Strict YAML access for start-up and tools: every error names the file, the
// line, the key path and the offending value, and unknown keys are errors
// (style rule 8).

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace clm::yaml {

/// "file:line: key.path: what" — the one line a user sees.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A node with the file it came from and its key path.
class Node {
 public:
  Node(std::shared_ptr<const std::string> file, YAML::Node node, std::string path);

  /// Largest YAML file load_file reads (docs/data-formats.md, "Size limits").
  static constexpr std::uint64_t kMaxFileBytes = 16u << 20;
  /// Parses `path`; throws Error with the parser's line on a syntax error, and
  /// for a file that is not a regular file or is larger than kMaxFileBytes
  /// (clm::read_regular_file's one-line messages).
  static Node load_file(const std::string& path);
  /// The text load_file parses (the same checks and errors), for a caller
  /// that also needs the bytes, e.g. their SHA-256.
  static std::string read_file(const std::string& path);
  /// Parses text that came from `origin` (used by tests and fuzzers).
  static Node load_string(const std::string& text, const std::string& origin);

  const std::string& path() const { return path_; }
  const std::string& file() const { return *file_; }
  int line() const;  ///< 1-based line, 0 if unknown

  bool is_map() const { return node_.IsMap(); }
  bool is_sequence() const { return node_.IsSequence(); }
  bool has(const std::string& key) const;
  /// Required child; throws "missing key".
  Node operator[](const std::string& key) const;
  std::optional<Node> optional(const std::string& key) const;
  /// Sequence element.
  Node at(std::size_t index) const;
  std::size_t size() const;

  /// Throws for any key of this map not in `allowed`.
  void expect_keys(std::initializer_list<std::string_view> allowed) const;
  /// Throws unless this is a map.
  void expect_map() const;

  double as_double() const;  ///< finite number, exact round trip of 17-digit text
  double as_double_in(double min, double max) const;
  double as_positive() const;
  long as_integer() const;
  long as_integer_in(long min, long max) const;
  bool as_bool() const;
  std::string as_string() const;
  std::vector<double> as_double_list() const;
  std::vector<int> as_int_list() const;
  /// rows × cols nested list [[...], ...]; rows/cols < 0 accept any size.
  Eigen::MatrixXd as_matrix(int rows, int cols) const;

  /// Throws Error("file:line: path: what").
  [[noreturn]] void fail(const std::string& what) const;
  std::string scalar_text() const;

 private:
  std::shared_ptr<const std::string> file_;
  YAML::Node node_;
  std::string path_;
};

/// Formats a double so that parsing the text gives back the same bits.
std::string format_double(double value);

/// Emits a double list / matrix in flow style with exact values.
void emit_double_list(YAML::Emitter& out, const double* values, std::size_t count);
void emit_matrix(YAML::Emitter& out, const Eigen::MatrixXd& matrix);

}  // namespace clm::yaml
