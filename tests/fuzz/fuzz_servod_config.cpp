// libFuzzer harness: the clm-servod configuration reader,
// daemon/servod/servod_config.hpp parse_servod_config on
// yaml::Node::load_string, with relative paths resolved against the source
// tree's config/ directory, where motor_file: motor-sim.yaml (and
// motor-sim-2coil.yaml) are valid, so the fuzzer gets past the motor file to
// the rest of the configuration.
//
// Refusal: clm::yaml::Error (the header promises file, line and key path).
// Invariant for an accepted configuration: the servo settings it produced
// validate.

#include "daemon/servod/servod_config.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string directory = clm::fuzz::source_path("config");
  clm::servod::ServodConfig config;
  try {
    config = clm::servod::parse_servod_config(
        clm::yaml::Node::load_string(clm::fuzz::as_text(data, size), "fuzz.yaml"), directory);
  } catch (const clm::yaml::Error&) {
    return 0;
  }
  config.servo.validate();  // an exception here escapes: a finding
  clm::fuzz::require(config.servo.period_s > 0.0 && config.loop.rate_hz > 0.0, "non-positive period");
  clm::fuzz::require(config.servo.protocol.is_valid(), "accepted an invalid CAN protocol configuration");
  return 0;
}
