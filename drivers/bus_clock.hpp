#pragma once
// The time base of a simulated bus: a bus whose far end is simulated in this
// process (drivers/sim/in_process_bus.hpp) has no time of its own, so before
// each SYNC the daemon's loop tells it the cycle's time. Real hardware keeps
// its own time and has none: the daemon then uses no_bus_clock().

#include <cstdint>

namespace clm::drivers {

class BusClock {
 public:
  virtual ~BusClock();
  /// The loop's time of the SYNC about to be sent [ns] (CLOCK_MONOTONIC on
  /// the real-time clock, the virtual time otherwise); what the bus receives
  /// from now on is stamped with it. Runs in the cycle: noexcept, no allocation.
  virtual void advance_to(std::int64_t time_ns) noexcept = 0;
};

/// The clock of a bus that keeps its own time: advance_to does nothing.
BusClock& no_bus_clock() noexcept;

}  // namespace clm::drivers
