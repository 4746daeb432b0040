// libFuzzer harness: the calibration file reader, commutation/model_file.hpp
// parse_calibration_file on yaml::Node::load_string.
//
// Refusal: clm::yaml::Error. Invariant for an accepted file: format → parse →
// format gives the same text.

#include "commutation/model_file.hpp"
#include "fuzz_support.hpp"

using clm::fuzz::require;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  clm::CalibrationFile file;
  try {
    file = clm::parse_calibration_file(clm::yaml::Node::load_string(clm::fuzz::as_text(data, size), "fuzz.yaml"));
  } catch (const clm::yaml::Error&) {
    return 0;
  }
  require(file.estimates().size() == file.coil_sets.size(), "estimates() lost coil sets");

  const std::string text = clm::format_calibration_file(file);
  clm::CalibrationFile again;
  try {
    again = clm::parse_calibration_file(clm::yaml::Node::load_string(text, "formatted.yaml"));
  } catch (const clm::yaml::Error& e) {
    require(false, "a formatted calibration file does not parse", std::string(e.what()) + "\n" + text);
  }
  const std::string text_again = clm::format_calibration_file(again);
  require(text == text_again, "calibration file format -> parse -> format changed the text",
          "first:\n" + text + "\nsecond:\n" + text_again);
  return 0;
}
