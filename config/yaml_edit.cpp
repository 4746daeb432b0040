#include "config/yaml_edit.hpp"

#include <optional>
#include <stdexcept>
#include <vector>

namespace clm::yaml {
namespace {

struct Lines {
  std::vector<std::string> lines;
  bool final_newline = true;
};

Lines split(const std::string& text) {
  Lines out;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t end = text.find('\n', at);
    if (end == std::string::npos) {
      out.lines.push_back(text.substr(at));
      out.final_newline = false;
      break;
    }
    out.lines.push_back(text.substr(at, end - at));
    at = end + 1;
  }
  return out;
}

std::string join(const Lines& in) {
  std::string out;
  for (std::size_t i = 0; i < in.lines.size(); ++i) {
    out += in.lines[i];
    if (i + 1 < in.lines.size() || in.final_newline) out += '\n';
  }
  return out;
}

std::size_t indentation(const std::string& line) { return line.find_first_not_of(' ') == std::string::npos ? line.size() : line.find_first_not_of(' '); }

bool blank_or_comment(const std::string& line) {
  const std::size_t first = line.find_first_not_of(" \t");
  return first == std::string::npos || line[first] == '#';
}

/// Where the comment of a `key: value` line starts (a '#' after a blank,
/// outside quotes), or npos.
std::size_t comment_start(const std::string& line, std::size_t from) {
  char quote = 0;
  for (std::size_t i = from; i < line.size(); ++i) {
    const char c = line[i];
    if (quote != 0) {
      if (c == '\\' && quote == '"') {
        ++i;
      } else if (c == quote) {
        quote = 0;
      }
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '#' && (i == 0 || line[i - 1] == ' ' || line[i - 1] == '\t')) {
      return i;
    }
  }
  return std::string::npos;
}

/// "name:" at `indent` with nothing but blanks or a comment after (a section
/// header) or any value after (a key line): the position after the colon.
std::optional<std::size_t> key_line(const std::string& line, std::size_t indent, std::string_view name) {
  if (indentation(line) != indent || line.compare(indent, name.size(), name) != 0) return std::nullopt;
  const std::size_t colon = indent + name.size();
  if (colon >= line.size() || line[colon] != ':') return std::nullopt;
  if (colon + 1 < line.size() && line[colon + 1] != ' ' && line[colon + 1] != '\t') return std::nullopt;
  return colon + 1;
}

struct Location {
  std::size_t section = 0;      ///< line of the section header
  std::size_t end = 0;          ///< one past the section's last line (its trailing blank lines excluded)
  std::size_t child_indent = 2;
  std::optional<std::size_t> key;  ///< line of the key
};

std::pair<std::string, std::string> split_key(std::string_view dotted_key) {
  const std::size_t dot = dotted_key.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == dotted_key.size() ||
      dotted_key.find('.', dot + 1) != std::string_view::npos) {
    throw std::invalid_argument("configuration key '" + std::string(dotted_key) + "': expected section.key");
  }
  return {std::string(dotted_key.substr(0, dot)), std::string(dotted_key.substr(dot + 1))};
}

std::optional<Location> locate(const Lines& in, std::string_view dotted_key) {
  const auto [section, key] = split_key(dotted_key);
  for (std::size_t i = 0; i < in.lines.size(); ++i) {
    const auto after = key_line(in.lines[i], 0, section);
    if (!after) continue;
    const std::string& header = in.lines[i];
    const std::size_t comment = comment_start(header, *after);
    if (header.find_first_not_of(" \t", *after) < std::min(comment, header.size())) {
      throw std::invalid_argument("configuration key '" + std::string(dotted_key) + "': section '" + section +
                                  "' is not in block style");
    }
    Location at;
    at.section = i;
    at.end = i + 1;
    bool indent_known = false;
    for (std::size_t k = i + 1; k < in.lines.size(); ++k) {
      const std::string& line = in.lines[k];
      if (blank_or_comment(line)) continue;
      if (indentation(line) == 0) break;
      if (!indent_known) {
        at.child_indent = indentation(line);
        indent_known = true;
      }
      at.end = k + 1;
      if (key_line(line, at.child_indent, key)) {
        if (at.key) {
          throw std::invalid_argument("configuration key '" + std::string(dotted_key) + "' appears twice");
        }
        at.key = k;
      }
    }
    return at;
  }
  return std::nullopt;
}

}  // namespace

std::string set_value(const std::string& text, std::string_view dotted_key, std::string_view value) {
  Lines in = split(text);
  const auto [section, key] = split_key(dotted_key);
  const std::optional<Location> at = locate(in, dotted_key);
  if (!at) {
    if (!in.lines.empty() && !in.final_newline) in.final_newline = true;
    in.lines.push_back(section + ":");
    in.lines.push_back("  " + key + ": " + std::string(value));
    in.final_newline = true;
    return join(in);
  }
  if (!at->key) {
    in.lines.insert(in.lines.begin() + static_cast<std::ptrdiff_t>(at->end),
                    std::string(at->child_indent, ' ') + key + ": " + std::string(value));
    return join(in);
  }
  std::string& line = in.lines[*at->key];
  const std::size_t after = at->child_indent + key.size() + 1;
  const std::size_t comment = comment_start(line, after);
  if (comment == std::string::npos && line.find_first_not_of(" \t", after) == std::string::npos) {
    throw std::invalid_argument("configuration key '" + std::string(dotted_key) + "': its value is on further lines");
  }
  std::string replaced = line.substr(0, after) + " " + std::string(value);
  if (comment != std::string::npos) {
    // Keep the comment where it was when the value fits before it.
    const std::size_t column = std::max(replaced.size() + 1, comment);
    replaced += std::string(column - replaced.size(), ' ') + line.substr(comment);
  }
  line = replaced;
  return join(in);
}

std::string remove_key(const std::string& text, std::string_view dotted_key) {
  Lines in = split(text);
  const std::optional<Location> at = locate(in, dotted_key);
  if (!at || !at->key) return text;
  const std::string& line = in.lines[*at->key];
  const std::size_t after = line.find(':', at->child_indent) + 1;
  const std::size_t comment = comment_start(line, after);
  if (line.find_first_not_of(" \t", after) >= std::min(comment, line.size())) {
    throw std::invalid_argument("configuration key '" + std::string(dotted_key) + "': its value is on further lines");
  }
  in.lines.erase(in.lines.begin() + static_cast<std::ptrdiff_t>(*at->key));
  return join(in);
}

std::string quoted(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    if (static_cast<unsigned char>(c) < 0x20) {
      constexpr char kHex[] = "0123456789abcdef";
      out += "\\u00";
      out += kHex[(c >> 4) & 0xf];
      out += kHex[c & 0xf];
      continue;
    }
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace clm::yaml
