// libFuzzer harness: the model file reader, commutation/model_file.hpp
// parse_model_file on yaml::Node::load_string.
//
// Refusal: clm::yaml::Error (the header promises file, line and key path).
// Invariants for an accepted file: format → parse → format gives the same
// text, and the model evaluates (plain and fused PGNN path) across and beyond
// its range without a sanitizer report.

#include <memory>
#include <vector>

#include "commutation/model.hpp"
#include "commutation/model_file.hpp"
#include "fuzz_support.hpp"

using clm::fuzz::require;

namespace {

void evaluate_everywhere(const clm::ElectromagneticModel& model) {
  const double pitch = model.pole_pitch_m;
  std::vector<double> positions{0.0, pitch, -pitch, 0.5, -0.5, 1e300, -1e300};
  if (model.kind == clm::ModelKind::kSpline) {
    const auto& knots = model.spline_basis;
    positions.insert(positions.end(), {knots.start_m, knots.end_m, 0.5 * knots.start_m + 0.5 * knots.end_m});
  } else {
    positions.push_back(model.normalisation.offset_m);
  }
  clm::StackedGain gain;
  clm::Wrench cogging;
  std::unique_ptr<clm::FusedPgnnEvaluator> fused;
  if (clm::FusedPgnnEvaluator::supports(model)) fused = std::make_unique<clm::FusedPgnnEvaluator>(model);
  for (double position : positions) {
    model.evaluate(position, gain, cogging);
    if (fused) fused->evaluate(position, gain, cogging);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  clm::ModelFile file;
  try {
    file = clm::parse_model_file(clm::yaml::Node::load_string(clm::fuzz::as_text(data, size), "fuzz.yaml"));
  } catch (const clm::yaml::Error&) {
    return 0;
  }
  evaluate_everywhere(file.model);

  const std::string text = clm::format_model_file(file);
  clm::ModelFile again;
  try {
    again = clm::parse_model_file(clm::yaml::Node::load_string(text, "formatted.yaml"));
  } catch (const clm::yaml::Error& e) {
    require(false, "a formatted model file does not parse", std::string(e.what()) + "\n" + text);
  }
  const std::string text_again = clm::format_model_file(again);
  require(text == text_again, "model file format -> parse -> format changed the text",
          "first:\n" + text + "\nsecond:\n" + text_again);
  return 0;
}
