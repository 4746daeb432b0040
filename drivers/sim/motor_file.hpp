#pragma once
// The simulated motor's YAML file (config/motor-sim.yaml, docs/simulator.md):
// `motor:` and `drive.commutation:` as every tool reads them
// (clm::read_motor_description), the drive's current limit and watchdog
// beside them, and the truth in `simulation:`. Loading validates everything
// and throws clm::yaml::Error "file:line: key.path: what"; unknown keys are
// errors. I/O: this is target clm::sim_file, not clm::sim.

#include <string>

#include "config/yaml_reader.hpp"
#include "drivers/sim/parameters.hpp"

namespace clm::sim {

/// Reads a parsed motor file. With `allow_other_sections`, top-level sections
/// other than motor, drive and simulation are left to other readers (a daemon
/// configuration that embeds the simulator); the three are always strict.
MotorParameters read_motor_parameters(const yaml::Node& root, bool allow_other_sections = false);

/// Loads and reads `path`.
MotorParameters load_motor_parameters(const std::string& path);

}  // namespace clm::sim
