#pragma once
// Edits of a block-style YAML configuration as text, so that everything the
// edit does not touch (comments, order, blank lines, other keys) stays byte
// for byte: `clm ctl save` and `clm commission --live --save` write values
// back into the file an engineer wrote. Two levels only, `section.key`, the
// shape of every clm-servo configuration; the value is YAML text as given
// (a number, a quoted string, a flow map). No I/O.

#include <string>
#include <string_view>

namespace clm::yaml {

/// `text` with `section.key` set to `value`: the key's value replaced on its
/// line (its comment kept), else a line `  key: value` added at the end of
/// the section, else the section added at the end. Throws
/// std::invalid_argument naming the key when `dotted_key` is not two names,
/// the section is written in flow style, or the key appears twice in it.
std::string set_value(const std::string& text, std::string_view dotted_key, std::string_view value);

/// `text` without the line of `section.key` (unchanged when there is none).
/// A key whose value continues on further lines is refused (std::invalid_argument).
std::string remove_key(const std::string& text, std::string_view dotted_key);

/// `text` as a double-quoted scalar: backslash and quote escaped, control
/// characters as \u00XX. Valid YAML and valid JSON alike.
std::string quoted(std::string_view text);

}  // namespace clm::yaml
