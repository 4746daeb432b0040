// libFuzzer harness: the simulated motor's file reader, drivers/sim/motor_file.hpp
// read_motor_parameters on yaml::Node::load_string, strict and with other
// top-level sections allowed (a daemon configuration embedding the motor).
//
// Refusal: clm::yaml::Error. Invariant for an accepted file: the simulated
// motor builds from it (the reader has checked everything the simulator
// needs) and its truth evaluates over and beyond the stroke.

#include "drivers/sim/motor.hpp"
#include "drivers/sim/motor_file.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = clm::fuzz::as_text(data, size);
  for (bool allow_other_sections : {false, true}) {
    clm::sim::MotorParameters parameters;
    try {
      parameters = clm::sim::read_motor_parameters(clm::yaml::Node::load_string(text, "fuzz.yaml"),
                                                   allow_other_sections);
    } catch (const clm::yaml::Error&) {
      continue;
    }
    // Throws nothing for parameters the reader accepted: an escaping
    // ParameterError is a finding (libFuzzer reports the abort).
    const clm::sim::SimulatedMotor motor(parameters);
    const double low = parameters.mechanics.end_stop_min_m;
    const double high = parameters.mechanics.end_stop_max_m;
    for (double position : {low, high, 0.5 * low + 0.5 * high, parameters.stroke_min_m, high + 1.0, low - 1.0}) {
      for (int l = 0; l < motor.coil_sets(); ++l) static_cast<void>(motor.true_gain(l, position));
      static_cast<void>(motor.true_cogging(position));
    }
  }
  return 0;
}
