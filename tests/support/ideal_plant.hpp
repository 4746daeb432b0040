#pragma once
// The ideal plant's copies of the simulated configurations (tests/CMakeLists.txt:
// tools/commission/plant_terms.py --write none): each configuration, its
// programs and its motor file without the plant's dynamics beyond a rigid
// mass (docs/simulator.md). For the tests of mechanisms that a current loop,
// delays, a mode, encoder noise or a disturbance would blur.

#include <string>

namespace clm::test {

/// The copy of `file` (config/servod.yaml, servod-2coil.yaml or
/// servod-phase-current.yaml) on the ideal plant.
inline std::string ideal_plant_path(const std::string& file = "config/servod.yaml") {
  const std::string name = file.substr(file.find_last_of('/') + 1);
  return std::string(CLM_IDEAL_PLANT_DIR) + "/" + name.substr(0, name.rfind(".yaml")) + "/" + name;
}

/// A file beside that copy: its motor file ("motor-sim.yaml") or a program ("programs/fig8.yaml").
inline std::string ideal_plant_file(const std::string& name, const std::string& file = "config/servod.yaml") {
  const std::string config = ideal_plant_path(file);
  return config.substr(0, config.find_last_of('/')) + "/" + name;
}

}  // namespace clm::test
