#pragma once
// The copies of the simulated configurations the tests run on
// (tests/CMakeLists.txt: tools/commission/plant_terms.py --write), each
// configuration with its programs and its motor file, the encoder absolute
// (no power-up offset, no homing):
// - the ideal plant: without the plant's dynamics beyond a rigid mass
//   (docs/simulator.md), for the tests of mechanisms that a current loop,
//   delays, a mode, encoder noise or a disturbance would blur;
// - the shipped plant: every term as shipped, for the tests of other
//   mechanisms than homing, which an unknown encoder zero would only delay.

#include <string>

namespace clm::test {

/// The copy of `file` (config/servod.yaml, servod-2coil.yaml or
/// servod-phase-current.yaml) in `directory`.
inline std::string config_copy_path(const std::string& directory, const std::string& file) {
  const std::string name = file.substr(file.find_last_of('/') + 1);
  return directory + "/" + name.substr(0, name.rfind(".yaml")) + "/" + name;
}

/// The copy of `file` on the ideal plant.
inline std::string ideal_plant_path(const std::string& file = "config/servod.yaml") {
  return config_copy_path(CLM_IDEAL_PLANT_DIR, file);
}

/// The copy of `file` on the shipped plant with an absolute encoder.
inline std::string absolute_encoder_path(const std::string& file = "config/servod.yaml") {
  return config_copy_path(CLM_ABSOLUTE_ENCODER_DIR, file);
}

/// A file beside a copy `config`: its motor file ("motor-sim.yaml") or a program ("programs/fig8.yaml").
inline std::string beside(const std::string& config, const std::string& name) {
  return config.substr(0, config.find_last_of('/')) + "/" + name;
}

/// A file beside the ideal plant's copy of `file`.
inline std::string ideal_plant_file(const std::string& name, const std::string& file = "config/servod.yaml") {
  return beside(ideal_plant_path(file), name);
}

/// A file beside the absolute-encoder copy of `file`.
inline std::string absolute_encoder_file(const std::string& name, const std::string& file = "config/servod.yaml") {
  return beside(absolute_encoder_path(file), name);
}

}  // namespace clm::test
