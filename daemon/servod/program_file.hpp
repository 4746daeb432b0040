#pragma once
// Move programs as files (config/programs/*.yaml, docs/servod.md): a start
// position and steps of jerk-limited moves with dwells.

#include <string>

#include "config/yaml_reader.hpp"
#include "daemon/control/trajectory.hpp"

namespace clm::servod {

struct ProgramFile {
  double start_m = 0.0;
  std::vector<control::ProgramStep> steps;
};

ProgramFile parse_program_file(const yaml::Node& root);
ProgramFile load_program_file(const std::string& path);

/// The program as the axis runs it from `hold_m`: when the axis is not at the
/// program's start, a first move takes it there with the first step's limits.
control::MoveProgram program_from(const ProgramFile& file, double hold_m);

}  // namespace clm::servod
