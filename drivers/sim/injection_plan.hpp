#pragma once
// The text of a fault-injection plan, shared by the bus-side injector of
// `clm sim --can` (bus_injector.hpp) and the in-process bus of the embedded
// simulated motor (in_process_bus.hpp): comma-separated steps
// "name[:count[:value]]", e.g. "drop-drive:3,push:40:3000". Each user maps
// the names to what it can do. No I/O.

#include <string>
#include <vector>

namespace clm::sim {

struct PlanItem {
  std::string text;    ///< the step as written, for messages
  std::string name;
  int count = 1;       ///< 1 … 1000; 1 when not written
  double value = 0.0;  ///< the third field, finite, when has_value
  bool has_value = false;
};

/// Splits `plan` into steps. Throws std::invalid_argument "injection plan:
/// step '<item>': …" for an empty step, a count that is not an integer in
/// 1 … 1000, a value that is not a finite number, or more than three fields.
std::vector<PlanItem> parse_plan_items(const std::string& plan);

}  // namespace clm::sim
