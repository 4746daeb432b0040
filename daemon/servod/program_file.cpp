#include "daemon/servod/program_file.hpp"

#include "daemon/servo/move_decision.hpp"

#include <cmath>

namespace clm::servod {

ProgramFile parse_program_file(const yaml::Node& root) {
  root.expect_keys({"format", "format_version", "description", "start_m", "steps"});
  if (root["format"].as_string() != "clm-servo-program") root["format"].fail("expected 'clm-servo-program'");
  root["format_version"].as_integer_in(1, 1);
  ProgramFile file;
  file.start_m = root["start_m"].as_double();
  const yaml::Node steps = root["steps"];
  if (steps.size() == 0) steps.fail("a program needs at least one step");
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const yaml::Node step = steps.at(i);
    step.expect_keys({"target_m", "velocity_m_per_s", "acceleration_m_per_s2", "jerk_m_per_s3", "dwell_s"});
    control::ProgramStep parsed{step["target_m"].as_double(),
                                {step["velocity_m_per_s"].as_positive(), step["acceleration_m_per_s2"].as_positive(),
                                 step["jerk_m_per_s3"].as_positive()},
                                step.has("dwell_s") ? step["dwell_s"].as_double_in(0.0, 3600.0) : 0.0};
    file.steps.push_back(parsed);
  }
  try {
    control::MoveProgram check(file.start_m, file.steps);
  } catch (const std::invalid_argument& e) {
    steps.fail(e.what());
  }
  return file;
}

ProgramFile load_program_file(const std::string& path) { return parse_program_file(yaml::Node::load_file(path)); }

ProgramFile fit_program(const ProgramFile& file, double min_m, double max_m, bool& scaled) {
  const double centre = 0.5 * (min_m + max_m);
  const double half = 0.5 * (max_m - min_m);
  double farthest = std::abs(file.start_m - centre);
  bool inside = file.start_m >= min_m && file.start_m <= max_m;
  for (const auto& step : file.steps) {
    farthest = std::max(farthest, std::abs(step.target_m - centre));
    inside = inside && step.target_m >= min_m && step.target_m <= max_m;
  }
  scaled = !inside;
  if (inside) return file;
  const double factor = 0.9 * half / farthest;
  ProgramFile fitted = file;
  fitted.start_m = centre + factor * (file.start_m - centre);
  for (auto& step : fitted.steps) step.target_m = centre + factor * (step.target_m - centre);
  return fitted;
}

control::MoveProgram program_from(const ProgramFile& file, double hold_m) {
  return servo::program_from_hold({file.start_m, file.steps}, hold_m);
}

}  // namespace clm::servod
