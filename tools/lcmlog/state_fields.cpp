#include "tools/lcmlog/state_fields.hpp"

#include <cstddef>
#include <iterator>
#include <limits>
#include <stdexcept>

#include "config/nearest_name.hpp"

namespace clm::lcmlog {

namespace {

using servo::CycleRecord;

StateField field(const char* name, double (*read)(const CycleRecord&, int)) { return StateField{name, read, -1}; }

double absent() { return std::numeric_limits<double>::quiet_NaN(); }

}  // namespace

std::vector<StateField> state_fields(int coil_sets) {
  std::vector<StateField> fields{
      field("utime", [](const CycleRecord& s, int) { return static_cast<double>(s.utime); }),
      field("cycle", [](const CycleRecord& s, int) { return static_cast<double>(s.cycle); }),
      field("t_s", [](const CycleRecord& s, int) { return s.t_s; }),
      field("r_m", [](const CycleRecord& s, int) { return s.r_m; }),
      field("r_dot_m_per_s", [](const CycleRecord& s, int) { return s.r_dot_m_per_s; }),
      field("r_ddot_m_per_s2", [](const CycleRecord& s, int) { return s.r_ddot_m_per_s2; }),
      field("y_m", [](const CycleRecord& s, int) { return s.y_m; }),
      field("e_m", [](const CycleRecord& s, int) { return s.e_m; }),
      field("F_star_N", [](const CycleRecord& s, int) { return s.F_star_N; }),
      field("u_fb_N", [](const CycleRecord& s, int) { return s.u_fb_N; }),
      field("u_ff_N", [](const CycleRecord& s, int) { return s.u_ff_N; }),
      field("Fy_star_N", [](const CycleRecord& s, int) { return s.Fy_star_N; }),
      field("Fx_star_N", [](const CycleRecord& s, int) { return s.Fx_star_N; }),
      field("Tz_star_Nm", [](const CycleRecord& s, int) { return s.Tz_star_Nm; }),
      field("Fy_N", [](const CycleRecord& s, int) { return s.Fy_N; }),
      field("Fx_N", [](const CycleRecord& s, int) { return s.Fx_N; }),
      field("Tz_Nm", [](const CycleRecord& s, int) { return s.Tz_Nm; }),
      field("commutation", [](const CycleRecord& s, int) { return static_cast<double>(s.commutation); }),
      field("coil_set", [](const CycleRecord& s, int) { return static_cast<double>(s.coil_set); }),
      field("delta_rad", [](const CycleRecord& s, int) { return s.delta_rad; }),
      field("coil_sets", [](const CycleRecord& s, int) { return static_cast<double>(s.coil_sets); }),
  };
  using PerCoilSet = double (*)(const CycleRecord&, int);
  const std::pair<const char*, PerCoilSet> per_coil_set[] = {
      {"magnitude_N", [](const CycleRecord& s, int l) { return l < s.coil_sets ? s.magnitude_N[static_cast<std::size_t>(l)] : absent(); }},
      {"setpoint_delta_rad",
       [](const CycleRecord& s, int l) { return l < s.coil_sets ? s.setpoint_delta_rad[static_cast<std::size_t>(l)] : absent(); }},
      {"ia_A", [](const CycleRecord& s, int l) { return l < s.coil_sets ? s.ia_A[static_cast<std::size_t>(l)] : absent(); }},
      {"ib_A", [](const CycleRecord& s, int l) { return l < s.coil_sets ? s.ib_A[static_cast<std::size_t>(l)] : absent(); }},
  };
  for (int l = 0; l < coil_sets; ++l) {
    for (const auto& [name, read] : per_coil_set) {
      fields.push_back(StateField{std::string(name) + "_" + std::to_string(l + 1), read, l});
    }
  }
  const StateField tail[] = {
      field("damping_engaged", [](const CycleRecord& s, int) { return s.damping_engaged ? 1.0 : 0.0; }),
      field("current_square_sum_A2", [](const CycleRecord& s, int) { return s.current_square_sum_A2; }),
      field("force_limited", [](const CycleRecord& s, int) { return s.force_limited ? 1.0 : 0.0; }),
      field("state", [](const CycleRecord& s, int) { return static_cast<double>(s.state); }),
      field("program_running", [](const CycleRecord& s, int) { return s.program_running ? 1.0 : 0.0; }),
      field("program_time_s", [](const CycleRecord& s, int) { return s.program_time_s; }),
      field("restricted", [](const CycleRecord& s, int) { return s.restricted ? 1.0 : 0.0; }),
      field("force_measured", [](const CycleRecord& s, int) { return s.force_measured ? 1.0 : 0.0; }),
      field("drive_profile", [](const CycleRecord& s, int) { return static_cast<double>(s.drive_profile); }),
  };
  fields.insert(fields.end(), std::begin(tail), std::end(tail));
  return fields;
}

StateField find_state_field(std::string_view name) {
  std::vector<std::string> names;
  for (StateField& f : state_fields(kMaxCoilSets)) {
    if (f.name == name) return f;
    names.push_back(std::move(f.name));
  }
  const std::string nearest = nearest_name(name, names);
  throw std::invalid_argument("'" + std::string(name) + "' is not a field of CLM_SERVO_STATE" +
                              (nearest.empty() ? "" : " (did you mean '" + nearest + "'?)") +
                              "; the fields are those of clm log2csv --format full");
}

}  // namespace clm::lcmlog
