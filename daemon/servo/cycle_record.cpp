#include "daemon/servo/cycle_record.hpp"

namespace clm::servo {

const char* name(CommutationMode mode) noexcept {
  switch (mode) {
    case CommutationMode::kOriginal: return "original";
    case CommutationMode::kClassical: return "classical";
    case CommutationMode::kPgnn: return "pgnn";
    case CommutationMode::kSpline: return "spline";
    case CommutationMode::kOracle: return "oracle";
    case CommutationMode::kExperiment: return "experiment";
  }
  return "unknown";
}

const char* name(ServoState state) noexcept {
  switch (state) {
    case ServoState::kDisabled: return "disabled";
    case ServoState::kEnabled: return "enabled";
    case ServoState::kFault: return "fault";
  }
  return "unknown";
}

}  // namespace clm::servo
