#pragma once
// Every field of a CLM_SERVO_STATE as a number, by its name (the
// servo_state_t, YAML and CSV name): the one list `clm log2csv --format full`
// writes and `clm scope` draws and triggers on.

#include <string>
#include <string_view>
#include <vector>

#include "daemon/servo/cycle_record.hpp"

namespace clm::lcmlog {

/// One field of a state as a number. Booleans are 0/1, enums their wire
/// value; a coil-set field of a coil set the state does not have is NaN.
struct StateField {
  std::string name;
  double (*read)(const servo::CycleRecord& state, int coil_set_index) = nullptr;
  int coil_set_index = -1;  ///< 0-based coil set of a per-coil-set field, −1 for the others
  double value(const servo::CycleRecord& state) const { return read(state, coil_set_index); }
};

/// Every field in the order of `clm log2csv --format full`; per coil set l
/// = 1..coil_sets: magnitude_N_<l>, setpoint_delta_rad_<l>, ia_A_<l>, ib_A_<l>.
std::vector<StateField> state_fields(int coil_sets);

/// The field called `name`, coil-set fields up to kMaxCoilSets included.
/// Throws std::invalid_argument naming it, with the nearest known name.
StateField find_state_field(std::string_view name);

}  // namespace clm::lcmlog
