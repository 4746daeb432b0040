#pragma once
// The feedforward file written by `clm ff-identify` (docs/data-formats.md).

#include <string>

#include "config/yaml_reader.hpp"
#include "daemon/control/position_controller.hpp"

namespace clm {

struct FeedforwardFile {
  control::FeedforwardParameters parameters;
  std::string data_sha256, created_utc, generator;
};

std::string format_feedforward_file(const FeedforwardFile& file);
FeedforwardFile parse_feedforward_file(const yaml::Node& root);
FeedforwardFile load_feedforward_file(const std::string& path);

}  // namespace clm
