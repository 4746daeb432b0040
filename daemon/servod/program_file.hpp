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

/// The program unchanged when every position lies within [min_m, max_m];
/// otherwise scaled about the centre of that range so that its farthest
/// position sits at 90 % of the half range (velocities, accelerations and
/// jerks are kept). `scaled` says whether it was.
ProgramFile fit_program(const ProgramFile& file, double min_m, double max_m, bool& scaled);

/// The program as the axis runs it from `hold_m`: when the axis is not at the
/// program's start, a first move takes it there with the first step's limits.
/// (servo::program_from_hold, what run_program runs)
control::MoveProgram program_from(const ProgramFile& file, double hold_m);

}  // namespace clm::servod
