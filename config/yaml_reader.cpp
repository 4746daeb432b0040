#include "config/yaml_reader.hpp"

#include "config/nearest_name.hpp"
#include "config/regular_file.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace clm::yaml {

Node::Node(std::shared_ptr<const std::string> file, YAML::Node node, std::string path)
    : file_(std::move(file)), node_(std::move(node)), path_(std::move(path)) {}

Node Node::load_string(const std::string& text, const std::string& origin) {
  auto file = std::make_shared<const std::string>(origin);
  try {
    YAML::Node root = YAML::Load(text);
    return Node(file, root, "");
  } catch (const YAML::Exception& e) {
    throw Error(origin + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
}

std::string Node::read_file(const std::string& path) {
  // Only a regular file, opened without blocking: a device or a pipe named by
  // mistake (motor_file: /dev/zero, docs/fuzzing.md) would exhaust memory or
  // block. The size limit keeps yaml-cpp's tree of a huge file from doing so.
  try {
    return read_regular_file(path, kMaxFileBytes, " for a YAML file");
  } catch (const FileError& e) {
    throw Error(e.what());
  }
}

Node Node::load_file(const std::string& path) { return load_string(read_file(path), path); }

int Node::line() const {
  if (!node_.IsDefined()) return 0;
  const auto mark = node_.Mark();
  return mark.line >= 0 ? mark.line + 1 : 0;
}

void Node::fail(const std::string& what) const {
  std::string location = *file_;
  if (const int l = line(); l > 0) location += ":" + std::to_string(l);
  throw Error(location + ": " + (path_.empty() ? std::string("(top level)") : path_) + ": " + what);
}

std::string Node::scalar_text() const { return node_.IsScalar() ? node_.Scalar() : std::string(); }

void Node::expect_map() const {
  if (!node_.IsMap()) fail("expected a map of keys");
}

bool Node::has(const std::string& key) const { return node_.IsMap() && node_[key].IsDefined(); }

Node Node::operator[](const std::string& key) const {
  expect_map();
  YAML::Node child = node_[key];
  const std::string child_path = path_.empty() ? key : path_ + "." + key;
  if (!child.IsDefined() || child.IsNull()) fail("missing key '" + key + "'");
  return Node(file_, child, child_path);
}

std::optional<Node> Node::optional(const std::string& key) const {
  if (!has(key)) return std::nullopt;
  return (*this)[key];
}

Node Node::at(std::size_t index) const {
  if (!node_.IsSequence()) fail("expected a list");
  if (index >= node_.size()) fail("list has no element " + std::to_string(index));
  return Node(file_, node_[index], path_ + "[" + std::to_string(index) + "]");
}

std::size_t Node::size() const {
  if (!node_.IsSequence()) fail("expected a list");
  return node_.size();
}

void Node::expect_keys(std::initializer_list<std::string_view> allowed) const {
  expect_map();
  std::vector<std::pair<std::string, int>> seen;  // key, line: a key given twice would be read once, silently
  for (const auto& entry : node_) {
    // An empty key ("? : 1") or a list or map as a key ("? [a, b]: 1") has no
    // text: refuse it here, with file and line, rather than let yaml-cpp's
    // conversion throw a message without either.
    if (!entry.first.IsScalar()) {
      Node(file_, entry.first, path_.empty() ? std::string("(key)") : path_ + ".(key)")
          .fail(entry.first.IsNull() ? "empty key" : "a list or map as a key; keys are plain names");
    }
    const std::string key = entry.first.as<std::string>();
    bool known = false;
    for (auto name : allowed) known = known || name == key;
    if (!known) {
      const std::string child_path = path_.empty() ? key : path_ + "." + key;
      const std::string nearest = nearest_name(key, std::vector<std::string>(allowed.begin(), allowed.end()));
      Node(file_, entry.first, child_path)
          .fail("unknown key '" + key + "'" + (nearest.empty() ? "" : "; did you mean '" + nearest + "'?"));
    }
    const Node key_node(file_, entry.first, path_.empty() ? key : path_ + "." + key);
    for (const auto& [earlier, line] : seen) {
      if (earlier == key) key_node.fail("given twice (first on line " + std::to_string(line) + ")");
    }
    seen.emplace_back(key, key_node.line());
  }
}

double Node::as_double() const {
  if (!node_.IsScalar()) fail("expected a number");
  const std::string& text = node_.Scalar();
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(begin, &end);
  if (end == begin || *end != '\0' || text.empty()) fail("expected a number, got '" + text + "'");
  if (!std::isfinite(value) || errno == ERANGE) fail("value '" + text + "' is not a finite number");
  return value;
}

double Node::as_double_in(double min, double max) const {
  const double value = as_double();
  if (value < min || value > max) {
    fail("value " + scalar_text() + " outside [" + format_double(min) + ", " + format_double(max) + "]");
  }
  return value;
}

double Node::as_positive() const {
  const double value = as_double();
  if (!(value > 0.0)) fail("value " + scalar_text() + " must be positive");
  return value;
}

long Node::as_integer() const {
  if (!node_.IsScalar()) fail("expected an integer");
  const std::string& text = node_.Scalar();
  long value = 0;
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  if (result.ec != std::errc() || result.ptr != text.data() + text.size() || text.empty()) {
    fail("expected an integer, got '" + text + "'");
  }
  return value;
}

long Node::as_integer_in(long min, long max) const {
  const long value = as_integer();
  if (value < min || value > max) {
    fail("value " + scalar_text() + " outside [" + std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  return value;
}

bool Node::as_bool() const {
  if (!node_.IsScalar()) fail("expected true or false");
  const std::string& text = node_.Scalar();
  if (text == "true") return true;
  if (text == "false") return false;
  fail("expected true or false, got '" + text + "'");
}

std::string Node::as_string() const {
  if (!node_.IsScalar()) fail("expected a string");
  return node_.Scalar();
}

std::vector<double> Node::as_double_list() const {
  std::vector<double> values;
  for (std::size_t i = 0; i < size(); ++i) values.push_back(at(i).as_double());
  return values;
}

std::vector<int> Node::as_int_list() const {
  std::vector<int> values;
  for (std::size_t i = 0; i < size(); ++i) values.push_back(static_cast<int>(at(i).as_integer_in(-2147483647L, 2147483647L)));
  return values;
}

Eigen::MatrixXd Node::as_matrix(int rows, int cols) const {
  const auto row_count = static_cast<int>(size());
  if (rows >= 0 && row_count != rows) {
    fail("expected " + std::to_string(rows) + " rows, got " + std::to_string(row_count));
  }
  Eigen::MatrixXd matrix;
  for (int r = 0; r < row_count; ++r) {
    const Node row = at(static_cast<std::size_t>(r));
    const auto col_count = static_cast<int>(row.size());
    if (r == 0) {
      if (cols >= 0 && col_count != cols) {
        row.fail("expected " + std::to_string(cols) + " columns, got " + std::to_string(col_count));
      }
      matrix.resize(row_count, col_count);
    } else if (col_count != matrix.cols()) {
      row.fail("expected " + std::to_string(matrix.cols()) + " columns like row 1, got " + std::to_string(col_count));
    }
    for (int c = 0; c < col_count; ++c) matrix(r, c) = row.at(static_cast<std::size_t>(c)).as_double();
  }
  return matrix;
}

std::string format_double(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  return buffer;
}

void emit_double_list(YAML::Emitter& out, const double* values, std::size_t count) {
  out << YAML::Flow << YAML::BeginSeq;
  for (std::size_t i = 0; i < count; ++i) out << format_double(values[i]);
  out << YAML::EndSeq;
}

void emit_matrix(YAML::Emitter& out, const Eigen::MatrixXd& matrix) {
  out << YAML::Flow << YAML::BeginSeq;
  for (Eigen::Index r = 0; r < matrix.rows(); ++r) {
    out << YAML::Flow << YAML::BeginSeq;
    for (Eigen::Index c = 0; c < matrix.cols(); ++c) out << format_double(matrix(r, c));
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq;
}

}  // namespace clm::yaml
