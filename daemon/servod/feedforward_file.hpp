#pragma once
// The feedforward file written by `clm ff-identify` (docs/data-formats.md).

#include <string>

#include "config/yaml_reader.hpp"
#include "daemon/control/position_controller.hpp"

namespace clm::servod {

struct FeedforwardFile {
  control::FeedforwardParameters parameters;
  std::string data_sha256, created_utc, generator;
};

/// The file's YAML text (format_version 1, exact doubles), ready to write.
std::string format_feedforward_file(const FeedforwardFile& file);
/// Reads a parsed feedforward file; throws yaml::Error naming file, line, key
/// and value for a wrong format, a missing or unknown key or a bad number.
FeedforwardFile parse_feedforward_file(const yaml::Node& root);
/// Loads and parses the file at `path`; throws as parse_feedforward_file, or
/// when the file cannot be read.
FeedforwardFile load_feedforward_file(const std::string& path);

}  // namespace clm::servod
