#include "daemon/servod/command_check.hpp"

#include <cmath>
#include <exception>
#include <utility>

#include "config/yaml_reader.hpp"
#include "daemon/servod/feedforward_file.hpp"

namespace clm::servod {
namespace {

using servo::CommandKind;
using servo::CommutationMode;

std::string check_positive(const char* field, double value) {
  if (value > 0.0) return "";
  return std::string("move_to: ") + field + " must be positive, got " + std::to_string(value);
}

}  // namespace

std::string check_command(servo::Command& command) {
  switch (command.kind) {
    case CommandKind::kJog:
      if (command.jog_velocity_m_per_s == 0.0) return "jog: velocity_m_per_s must not be 0 (its sign is the direction)";
      [[fallthrough]];
    case CommandKind::kMoveTo:
      for (const auto& reason : {check_positive("velocity_m_per_s", command.limits.velocity_m_per_s),
                                 check_positive("acceleration_m_per_s2", command.limits.acceleration_m_per_s2),
                                 check_positive("jerk_m_per_s3", command.limits.jerk_m_per_s3)}) {
        if (!reason.empty()) return reason;
      }
      return "";
    case CommandKind::kSetCommutation:
      if (command.commutation == CommutationMode::kExperiment) {
        return "set_commutation: mode " + std::to_string(static_cast<int>(command.commutation)) +
               " is not a commutation law (0 original .. 4 oracle); experiments use set_experiment";
      }
      return "";
    case CommandKind::kLoadModel: {
      if (command.commutation == CommutationMode::kPgnn || command.commutation == CommutationMode::kSpline) return "";
      // servo_command_t has no mode field: the model file's own `kind:`
      // says which law it replaces.
      const std::string path(command.path.view());
      std::string kind;
      try {
        kind = yaml::Node::load_file(path)["kind"].as_string();
      } catch (const std::exception& e) {
        return std::string("load_model: ") + e.what();
      }
      if (kind == "pgnn") {
        command.commutation = CommutationMode::kPgnn;
      } else if (kind == "spline") {
        command.commutation = CommutationMode::kSpline;
      } else {
        return "load_model: " + path + ": kind: expected pgnn or spline, got '" + kind + "'";
      }
      return "";
    }
    case CommandKind::kLoadFeedforward: {
      if (command.path.empty()) return "";
      // Read and checked here, off the cycle; the cycle only receives the
      // three parameters through its command queue.
      const std::string path(command.path.view());
      try {
        command.feedforward = load_feedforward_file(path).parameters;
      } catch (const std::exception& e) {
        return std::string("load_feedforward: ") + e.what();
      }
      const auto& ff = command.feedforward;
      for (const auto& [key, value] : {std::pair{"mass_kg", ff.mass_kg}, std::pair{"viscous_N_s_per_m", ff.viscous_N_s_per_m},
                                       std::pair{"coulomb_N", ff.coulomb_N}}) {
        if (!std::isfinite(value)) return "load_feedforward: " + path + ": " + key + " is not a finite number";
      }
      return "";
    }
    case CommandKind::kEnable:
    case CommandKind::kDisable:
    case CommandKind::kClearFault:
    case CommandKind::kStop:
    case CommandKind::kQuickStop:
    case CommandKind::kHome:
    case CommandKind::kRunProgram:
    case CommandKind::kSetExperiment:
    case CommandKind::kLoadCalibration:
    case CommandKind::kGetParameter:  // the daemon checks name and value (parameters.hpp)
    case CommandKind::kSetParameter:
      return "";
    case CommandKind::kTakeControl:
    case CommandKind::kReleaseControl:
    case CommandKind::kRenewControl:
      return std::string(servo::route(command.kind).name) + " is answered by the command authority, not the daemon";
  }
  return "unknown command " + std::to_string(static_cast<int>(command.kind));
}

}  // namespace clm::servod
