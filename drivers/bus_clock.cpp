#include "drivers/bus_clock.hpp"

namespace clm::drivers {
namespace {

class NoBusClock final : public BusClock {
 public:
  void advance_to(std::int64_t /*time_ns*/) noexcept override {}
};

NoBusClock g_no_bus_clock;

}  // namespace

BusClock::~BusClock() = default;

BusClock& no_bus_clock() noexcept { return g_no_bus_clock; }

}  // namespace clm::drivers
