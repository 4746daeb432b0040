#pragma once
// The name a user most likely meant: for unknown options and subcommands
// (config/command_line.hpp) and unknown YAML keys (config/yaml_reader.hpp).

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace clm {

/// Optimal string alignment distance: insertions, deletions, substitutions
/// and transpositions of adjacent characters, each 1.
std::size_t edit_distance(std::string_view a, std::string_view b);

/// The entry of `candidates` nearest to `typed` (edit_distance), the first
/// one on a tie; empty when even the nearest differs in more than a third of
/// `typed`'s characters (at least 1 edit is always allowed).
std::string nearest_name(std::string_view typed, const std::vector<std::string>& candidates);

}  // namespace clm
