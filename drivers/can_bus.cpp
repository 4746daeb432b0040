#include "drivers/can_bus.hpp"

namespace clm::drivers {

CanBus::~CanBus() = default;

const char* to_string(BusState state) noexcept {
  switch (state) {
    case BusState::kActive: return "active";
    case BusState::kErrorWarning: return "error warning";
    case BusState::kErrorPassive: return "error passive";
    case BusState::kBusOff: return "bus off";
  }
  return "unknown";
}

}  // namespace clm::drivers
