#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <cstdio>
#include <sstream>
#include <vector>

#include "clm_lcm/servo_status_t.hpp"
#include "config/yaml_edit.hpp"
#include "tools/commission/commission.hpp"
#include "tools/data/csv_table.hpp"

namespace clm::commission {
namespace {

// The paper's Table 2 and tracking figures (filtered, unfiltered).
struct PaperRow {
  const char* name;
  double filtered[3];
  double unfiltered[3];
  double tracking_mse_m2;  // NaN where the paper gives none
};
const PaperRow kPaper[] = {
    {"original", {52.8, 0.111, 0.327}, {53.4, 0.234, 0.781}, NAN},
    {"classical", {27.4, 0.141, 0.436}, {28.1, 0.307, 1.13}, 2.75e-8},
    {"pgnn", {2.45, 0.056, 0.180}, {3.08, 0.223, 0.930}, 5.94e-9},
};

/// The servo_status_t fingerprint (lcm-gen's, the first 8 bytes of every
/// encoding) as 16 hex digits: the plotter decodes the logs' status messages
/// only when it matches, instead of carrying a copy that goes stale.
std::string status_fingerprint_hex() {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx",
                static_cast<unsigned long long>(static_cast<std::uint64_t>(clm_lcm::servo_status_t::getHash())));
  return text;
}

std::string number(double value) {
  if (!std::isfinite(value)) return "null";
  return data::shortest_double(value);
}

std::string triple(const std::array<double, 3>& values) {
  return "[" + number(values[0]) + ", " + number(values[1]) + ", " + number(values[2]) + "]";
}

std::string triple(const Eigen::Vector3d& values) { return triple(std::array<double, 3>{values[0], values[1], values[2]}); }

/// The simulator's measures of a law's force error, as JSON members after a
/// comma; "" without a simulator (live).
std::string truth_members(const CommutationResult& r) {
  if (!r.truth_known) return "";
  std::ostringstream out;
  out << ", \"true_electromagnetic_mse\": {\"filtered\": " << triple(r.true_mse.filtered)
      << ", \"unfiltered\": " << triple(r.true_mse.unfiltered) << "}"
      << ", \"static_electromagnetic_mse\": {\"filtered\": " << triple(r.static_mse.filtered)
      << ", \"unfiltered\": " << triple(r.static_mse.unfiltered) << "}";
  return out.str();
}


const CommutationResult* find(const Report& report, const std::string& name) {
  for (const auto& r : report.results) {
    if (r.name == name && r.evaluated) return &r;
  }
  return nullptr;
}

/// 1 − the oracle's tracking MSE over the recommended law's: the share of the
/// law's tracking error its commutation causes (commutation_share_summary).
std::optional<double> commutation_share(const Report& report) {
  const auto* oracle = find(report, "oracle");
  const auto* recommended = find(report, report.recommended);
  if (oracle == nullptr || recommended == nullptr || !(recommended->tracking_mse_m2 > 0.0)) return std::nullopt;
  return 1.0 - oracle->tracking_mse_m2 / recommended->tracking_mse_m2;
}

std::string fixed(double value, const char* format = "%.3g") {
  if (!std::isfinite(value)) return "–";
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), format, value);
  return buffer;
}

const data::LawScore* scored(const Report& report, const std::string& law) {
  for (const auto& entry : report.law_scores) {
    if (entry.law == law) return &entry;
  }
  return nullptr;
}

// The calibrated classical law the improvements are measured against: the
// force sensor's calibration, else the one from positions.
const CommutationResult* calibrated_classical(const Report& report) {
  if (const auto* classical = find(report, "classical")) return classical;
  return find(report, "classical-position");
}

// Calibrated classical over `law`: commutation MSE y, x, z (filtered; NaN
// without a force sensor) and tracking MSE. Larger is better.
struct Improvement {
  std::array<double, 3> force{};
  double tracking = 0.0;
};
Improvement improvement(const CommutationResult& classical, const CommutationResult& law) {
  Improvement ratio;
  for (std::size_t q = 0; q < 3; ++q) ratio.force[q] = classical.mse.filtered[q] / law.mse.filtered[q];
  ratio.tracking = classical.tracking_mse_m2 / law.tracking_mse_m2;
  return ratio;
}


void identification_json(std::ostringstream& out, const std::vector<data::CoilSetIdentification>& entries) {
  out << "[";
  for (std::size_t l = 0; l < entries.size(); ++l) {
    const auto& r = entries[l].report;
    out << (l ? ", " : "") << "{\"coil_set\": " << l + 1 << ", \"training_samples\": " << entries[l].training_samples
        << ", \"validation_samples\": " << entries[l].validation_samples
        << ", \"physics_training_N2\": " << triple(r.physics_training)
        << ", \"model_training_N2\": " << triple(r.model_training)
        << ", \"physics_validation_N2\": " << triple(r.physics_validation)
        << ", \"model_validation_N2\": " << triple(r.model_validation)
        << ", \"refit_on_all_data\": " << (r.refit_on_all_data ? "true" : "false")
        << ", \"physics_fit_N2\": " << triple(r.physics_fit) << ", \"model_fit_N2\": " << triple(r.model_fit)
        << ", \"regularised_cost\": " << number(r.regularised_cost) << ", \"best_restart\": " << r.best_restart
        << ", \"proposition_4_1_holds\": "
        << ((r.proposition_holds[0] && r.proposition_holds[1] && r.proposition_holds[2]) ? "true" : "false")
        << ", \"regressor_condition\": " << number(r.regressors.condition)
        << ", \"linear_parameters\": " << r.regressors.parameters
        << ", \"dependent_directions\": " << r.regressors.dependent
        << ", \"unexcited_parameters\": " << r.regressors.unexcited << ", \"excitation_gaps\": [";
    for (std::size_t g = 0; g < r.excitation_gaps.size(); ++g) {
      const auto& gap = r.excitation_gaps[g];
      out << (g ? ", " : "") << "{\"low_m\": " << number(gap.low_m) << ", \"high_m\": " << number(gap.high_m)
          << ", \"lack\": " << yaml::quoted(identification::describe(gap.lack)) << "}";
    }
    out << "], \"warnings\": [";
    const auto warnings = identification::identification_warnings(r.regressors, r.excitation_gaps);
    for (std::size_t w = 0; w < warnings.size(); ++w) out << (w ? ", " : "") << yaml::quoted(warnings[w]);
    out << "]}";
  }
  out << "]";
}

void selection_json(std::ostringstream& out, const data::IdentifySummary& summary) {
  const auto& offset = summary.sensor_offset;
  out << "{\"nuisance_identified\": " << (summary.nuisance ? "true" : "false");
  if (!summary.nuisance_skipped.empty()) out << ", \"nuisance_skipped\": " << yaml::quoted(summary.nuisance_skipped);
  if (summary.nuisance) {
    out << ", \"sensor_offset\": {\"offset_y_N\": " << number(offset.offset_N) << ", \"mass_kg\": "
        << number(offset.mass_kg) << ", \"viscous_N_s_per_m\": " << number(offset.viscous_N_s_per_m)
        << ", \"coulomb_N\": " << number(offset.coulomb_N) << ", \"residual_rms_N\": " << number(offset.residual_rms_N)
        << ", \"condition\": " << number(offset.condition) << ", \"samples\": " << offset.samples << "}";
    out << ", \"direction_force\": " << (summary.direction_force ? "true" : "false")
        << ", \"direction_force_inflation\": " << number(summary.direction_force_inflation);
    if (!summary.direction_force_skipped.empty()) {
      out << ", \"direction_force_skipped\": " << yaml::quoted(summary.direction_force_skipped);
    }
    out << ", \"direction_smoothing\": [";
    for (std::size_t k = 0; k < summary.direction_smoothing_scores.size(); ++k) {
      out << (k ? ", " : "") << "{\"velocity_m_per_s\": " << number(summary.direction_smoothing_scores[k].first)
          << ", \"validation_score\": " << number(summary.direction_smoothing_scores[k].second) << "}";
    }
    out << "]";
  }
  out << ", \"trials\": [";
  for (std::size_t k = 0; k < summary.trials.size(); ++k) {
    const auto& trial = summary.trials[k];
    out << (k ? ", " : "") << "{\"capacity\": " << yaml::quoted(trial.capacity) << ", \"validation_score\": "
        << number(trial.validation_score) << ", \"chosen\": " << (k == summary.chosen ? "true" : "false")
        << ", \"direction_force_N_N_Nm\": [";
    for (std::size_t l = 0; l < trial.coil_sets.size(); ++l) {
      out << (l ? ", " : "") << triple(trial.coil_sets[l].report.direction_force.amplitude);
    }
    out << "]}";
  }
  out << "]}";
}

void calibration_json(std::ostringstream& out, const CalibrationFile& file) {
  out << "[";
  for (std::size_t l = 0; l < file.coil_sets.size(); ++l) {
    const auto& c = file.coil_sets[l];
    out << (l ? ", " : "") << "{\"coil_set\": " << l + 1
        << ", \"motor_constant_N_per_A\": " << number(c.estimate.motor_constant_N_per_A)
        << ", \"phase_offset_rad\": " << number(c.estimate.phase_offset_rad) << ", \"gain_ratio\": ["
        << number(c.gain_ratio[0]) << ", " << number(c.gain_ratio[1]) << "], \"residual_rms_N\": ["
        << number(c.residual_rms_N[0]) << ", " << number(c.residual_rms_N[1]) << "]";
    if (c.quality) {
      const CalibrationQuality& q = *c.quality;
      out << ", \"gain_ratio_standard_error\": [" << number(q.gain_ratio_standard_error[0]) << ", "
          << number(q.gain_ratio_standard_error[1]) << "], \"separation_condition\": "
          << number(q.separation_condition) << ", \"offset_inflation\": [" << number(q.offset_inflation[0]) << ", "
          << number(q.offset_inflation[1]) << "], \"warnings\": [";
      const auto warnings = calibration_warnings(c.gain_ratio.data(), q);
      for (std::size_t w = 0; w < warnings.size(); ++w) out << (w ? ", " : "") << yaml::quoted(warnings[w]);
      out << "]";
    }
    out << "}";
  }
  out << "]";
}

}  // namespace

std::string commutation_share_summary(const Report& report) {
  const auto* recommended = find(report, report.recommended);
  std::string live;
  if (recommended != nullptr && recommended->tracking_split.total_m2 > 0.0) {
    const control::TrackingSplit& s = recommended->tracking_split;
    live = "commutation's frequencies (velocity / pole pitch times 1.." + std::to_string(s.harmonics) +
           ") carry " + fixed(100.0 * s.commutation_m2 / s.total_m2, "%.0f") + " % of the recommended law's (" +
           report.recommended + ") tracking MSE, the rest " + fixed(100.0 * s.rest_m2 / s.total_m2, "%.0f") +
           " % (live split, no simulator needed)";
  }
  const std::optional<double> share = commutation_share(report);
  if (!share) return live;
  const std::string text =
      *share >= 0.0 ? fixed(100.0 * *share, "%.0f") + " %"
                    : "none measurable (the oracle's tracking MSE is " + fixed(1.0 - *share, "%.2f") + "x the law's)";
  return "commutation's share of the recommended law's (" + report.recommended + ") tracking MSE: " + text +
         " (1 - the oracle's tracking MSE over the law's; the rest is the plant's: disturbance, noise, the loop)" +
         (live.empty() ? "" : "; the " + live);
}

namespace {

/// A law's budget, its parts named, in order.
std::vector<std::pair<std::string, double>> budget_parts(const ErrorBudget& b, const LawBudget& law) {
  return {{"the loop with the oracle, through the plant's dynamics", b.loop_m2},
          {"the force disturbance", b.disturbance_m2},
          {"the encoder", b.encoder_m2},
          {"the commutation (" + law.law + " over the oracle)", law.commutation_m2}};
}

std::string percent_of(double part, double whole) { return fixed(100.0 * part / whole, "%.1f") + " %"; }

}  // namespace

std::string error_budget_summary(const Report& report) {
  const std::optional<LawBudget> law = law_budget(report, report.recommended);
  if (!law || !(law->whole_m2 > 0.0)) return "";
  std::string text =
      "error budget of the recommended law (" + law->law + "), tracking MSE " + fixed(law->whole_m2) + " m^2:";
  for (const auto& [name, value] : budget_parts(report.budget, *law)) {
    text += " " + name + " " + percent_of(value, law->whole_m2) + ",";
  }
  text.pop_back();
  return text + "; together " + percent_of(law->sum_m2, law->whole_m2) + " (the sources' interaction " +
         percent_of(law->whole_m2 - law->sum_m2, law->whole_m2) + ")";
}

std::string position_summary(const Report& report) {
  if (!report.from_position) return "";
  const auto* position = find(report, "spline-position");
  if (!position) return "";
  const auto ratio = [](double value) { return fixed(value, "%.2f") + "x"; };
  std::string text = "from positions (mass " + fixed(report.position.mass_kg, "%.4g") + " kg from " +
                     report.position_mass_source +
                     (report.payload_kg > 0.0 ? ", whose response was " + fixed(report.payload_ratio, "%.4f") +
                                                    "x as slow"
                                              : std::string()) +
                     "):";
  // Beside the force-sensor law of the same run, when there is one.
  if (const auto* forces = find(report, report.force_recommended)) {
    const std::string law = report.force_recommended;
    text += " spline-position tracking MSE " + ratio(position->tracking_mse_m2 / forces->tracking_mse_m2) +
            " the force-sensor " + law + "'s;";
    if (position->truth_known && forces->truth_known) {
      text += " true y MSE " + ratio(position->true_mse.filtered[0] / forces->true_mse.filtered[0]) +
              " the force-sensor " + law + "'s;";
    }
  }
  if (const auto* classical = find(report, "classical")) {
    text += " classical / spline-position tracking " + ratio(classical->tracking_mse_m2 / position->tracking_mse_m2) + ";";
  }
  for (const char* other : {"classical-position", "original"}) {
    if (const auto* law = find(report, other)) {
      text += std::string(" ") + other + " / spline-position tracking " +
              ratio(law->tracking_mse_m2 / position->tracking_mse_m2) + ";";
    }
  }
  double from_position_s = 0.0, from_force_s = 0.0;
  for (const auto& entry : report.steps) {
    if (entry.step == "identify from positions") from_position_s = entry.wall_s;
    if (entry.step == "identify spline") from_force_s = entry.wall_s;
  }
  if (from_force_s > 0.0) {
    text += " identification wall time " + ratio(from_position_s / from_force_s) + " the force-sensor spline's;";
  }
  text.pop_back();
  return text;
}

std::string report_json(const Report& report) {
  std::ostringstream out;
  out << "{\n  \"schema\": \"clm-servo-report\",\n  \"schema_version\": 1,\n";
  out << "  \"config\": " << yaml::quoted(report.config_path) << ",\n  \"coil_sets\": " << report.coil_sets << ",\n";
  out << "  \"encoder_reference\": {\"method\": " << yaml::quoted(report.encoder_reference.method)
      << ", \"position_m\": " << yaml::format_double(report.encoder_reference.position_m) << "},\n";
  out << "  \"notes\": [";
  for (std::size_t k = 0; k < report.notes.size(); ++k) out << (k ? ", " : "") << yaml::quoted(report.notes[k]);
  out << "],\n";
  out << "  \"commutations\": {\n";
  bool first = true;
  for (const auto& r : report.results) {
    out << (first ? "" : ",\n") << "    " << yaml::quoted(r.name) << ": ";
    first = false;
    if (!r.evaluated) {
      out << "{\"evaluated\": false, \"reason\": " << yaml::quoted(r.skipped_reason) << "}";
      continue;
    }
    out << "{\"evaluated\": true, \"commutation_mse\": {\"filtered\": " << triple(r.mse.filtered)
        << ", \"unfiltered\": " << triple(r.mse.unfiltered) << "}";
    out << truth_members(r);
    out << ", \"tracking_mse_m2\": " << number(r.tracking_mse_m2)
        << ", \"tracking_split\": {\"commutation_m2\": " << number(r.tracking_split.commutation_m2)
        << ", \"rest_m2\": " << number(r.tracking_split.rest_m2)
        << ", \"harmonics\": " << r.tracking_split.harmonics << "}"
        << ", \"feedforward\": {\"mass_kg\": " << number(r.feedforward.mass_kg)
        << ", \"viscous_N_s_per_m\": " << number(r.feedforward.viscous_N_s_per_m)
        << ", \"coulomb_N\": " << number(r.feedforward.coulomb_N) << "}"
        << ", \"mean_current_square_A2\": " << number(r.mean_current_square_A2)
        << ", \"damping_cycles\": " << r.damping_cycles << ", \"force_limited_cycles\": " << r.force_limited_cycles << "}";
  }
  out << "\n  },\n";
  out << "  \"validation\": {\"program\": " << yaml::quoted(report.validation_program) << ", \"commutations\": {";
  for (std::size_t k = 0; k < report.validation.size(); ++k) {
    const auto& r = report.validation[k];
    out << (k ? ", " : "") << yaml::quoted(r.name) << ": ";
    if (!r.evaluated) {
      out << "{\"evaluated\": false}";
      continue;
    }
    out << "{\"evaluated\": true, \"commutation_mse\": {\"filtered\": " << triple(r.mse.filtered)
        << ", \"unfiltered\": " << triple(r.mse.unfiltered) << "}" << truth_members(r)
        << ", \"tracking_mse_m2\": " << number(r.tracking_mse_m2) << "}";
  }
  out << "}},\n";
  const auto* classical = find(report, "classical");
  const auto* pgnn = find(report, "pgnn");
  const auto* spline = find(report, "spline");
  out << "  \"ratios\": {";
  const char* separator = "";  // between the members written so far and the next
  if (classical && pgnn) {
    separator = ", ";
    out << "\"classical_over_pgnn_commutation_mse_filtered\": " << triple(std::array<double, 3>{
        classical->mse.filtered[0] / pgnn->mse.filtered[0], classical->mse.filtered[1] / pgnn->mse.filtered[1],
        classical->mse.filtered[2] / pgnn->mse.filtered[2]})
        << ", \"classical_over_pgnn_tracking_mse\": " << number(classical->tracking_mse_m2 / pgnn->tracking_mse_m2);
  }
  if (classical && spline) {
    out << separator << "\"classical_over_spline_commutation_mse_filtered\": " << triple(std::array<double, 3>{
        classical->mse.filtered[0] / spline->mse.filtered[0], classical->mse.filtered[1] / spline->mse.filtered[1],
        classical->mse.filtered[2] / spline->mse.filtered[2]})
        << ", \"classical_over_spline_tracking_mse\": " << number(classical->tracking_mse_m2 / spline->tracking_mse_m2);
    separator = ", ";
  }
  if (const auto* oracle = find(report, "oracle")) {
    out << separator << "\"tracking_mse_over_oracle\": {";
    separator = ", ";
    bool first_ratio = true;
    for (const auto& r : report.results) {
      if (!r.evaluated) continue;
      out << (first_ratio ? "" : ", ") << yaml::quoted(r.name) << ": " << number(r.tracking_mse_m2 / oracle->tracking_mse_m2);
      first_ratio = false;
    }
    out << "}";
  }
  if (const auto* reference = calibrated_classical(report)) {
    out << separator << "\"improvement_over_classical\": {\"classical\": "
        << yaml::quoted(reference->name);
    for (const auto& r : report.results) {
      if (!r.evaluated || &r == reference) continue;
      const Improvement ratio = improvement(*reference, r);
      out << ", " << yaml::quoted(r.name) << ": {\"commutation_mse_filtered\": " << triple(ratio.force)
          << ", \"tracking_mse\": " << number(ratio.tracking) << "}";
    }
    out << "}";
  }
  out << "},\n";
  out << "  \"recommended\": {\"law\": " << yaml::quoted(report.recommended) << ", \"why\": " << yaml::quoted(report.recommendation)
      << ", \"force_sensor_law\": " << yaml::quoted(report.force_recommended) << "},\n";
  if (const ErrorBudget& b = report.budget; b.computed) {
    out << "  \"error_budget\": {\"loop_m2\": " << number(b.loop_m2) << ", \"disturbance_m2\": "
        << number(b.disturbance_m2) << ", \"encoder_m2\": " << number(b.encoder_m2) << ", \"laws\": {";
    const char* between = "";
    for (const auto& r : report.results) {
      const std::optional<LawBudget> law = law_budget(report, r.name);
      if (!law) continue;
      out << between << yaml::quoted(law->law) << ": {\"whole_m2\": " << number(law->whole_m2)
          << ", \"commutation_m2\": " << number(law->commutation_m2) << ", \"sum_m2\": " << number(law->sum_m2)
          << "}";
      between = ", ";
    }
    out << "}},\n";
  } else {
    out << "  \"error_budget\": null,\n";
  }
  out << "  \"validation_scores\": {";
  for (std::size_t k = 0; k < report.law_scores.size(); ++k) {
    const auto& entry = report.law_scores[k];
    std::size_t blocks = 0;
    for (const auto& coil_set : entry.blocks) blocks += coil_set.size();
    out << (k ? ", " : "") << yaml::quoted(entry.law) << ": {\"score\": " << number(entry.score.value)
        << ", \"standard_error\": " << number(entry.score.standard_error) << ", \"held_out_blocks\": " << blocks;
    if (const auto* recommended = scored(report, report.recommended)) {
      const data::ScoreEstimate d = data::score_difference(entry, *recommended);
      out << ", \"minus_recommended\": {\"score\": " << number(d.value)
          << ", \"standard_error\": " << number(d.standard_error) << "}";
    }
    out << "}";
  }
  out << "},\n";
  const data::Verdict& verdict = report.verdict;
  out << "  \"verdict\": {\"recommended\": " << yaml::quoted(report.recommended) << ", \"decided_by\": "
      << yaml::quoted(report.decided_by) << ", \"tie\": " << (verdict.tie ? "true" : "false") << ", \"tied\": [";
  for (std::size_t k = 0; k < verdict.tied.size(); ++k) out << (k ? ", " : "") << yaml::quoted(verdict.tied[k]);
  out << "], \"runner_up\": " << (verdict.runner_up.empty() ? "null" : yaml::quoted(verdict.runner_up))
      << ", \"margin_score\": " << number(verdict.margin_score)
      << ", \"margin_standard_errors\": " << number(verdict.margin_standard_errors)
      << ", \"tie_standard_errors\": " << number(data::kTieStandardErrors) << ", \"tie_order\": [";
  for (std::size_t k = 0; k < std::size(kTieOrder); ++k) out << (k ? ", " : "") << yaml::quoted(kTieOrder[k]);
  out << "]";
  const auto* reference = calibrated_classical(report);
  const auto* recommended = find(report, report.recommended);
  if (reference && recommended && recommended != reference) {
    const Improvement ratio = improvement(*reference, *recommended);
    out << ", \"classical_over_recommended_commutation_mse_y\": " << number(ratio.force[0])
        << ", \"classical_over_recommended_tracking_mse\": " << number(ratio.tracking);
  }
  const std::optional<double> share = commutation_share(report);
  out << ", \"commutation_share_of_tracking_mse\": " << (share ? number(*share) : std::string("null"));
  out << "},\n";
  out << "  \"selection\": {\"pgnn\": ";
  selection_json(out, report.pgnn_selection);
  out << ", \"spline\": ";
  selection_json(out, report.spline_selection);
  out << "},\n";
  out << "  \"calibration\": {\"algorithm1\": ";
  calibration_json(out, report.calibration_paper);
  out << ", \"offset_robust\": ";
  calibration_json(out, report.calibration_robust);
  out << "},\n  \"identification\": {\"pgnn\": ";
  identification_json(out, report.pgnn);
  out << ", \"spline\": ";
  identification_json(out, report.spline);
  out << "},\n  \"paper\": {";
  for (std::size_t k = 0; k < std::size(kPaper); ++k) {
    const auto& row = kPaper[k];
    out << (k ? ", " : "") << yaml::quoted(row.name) << ": {\"commutation_mse\": {\"filtered\": "
        << triple(std::array<double, 3>{row.filtered[0], row.filtered[1], row.filtered[2]}) << ", \"unfiltered\": "
        << triple(std::array<double, 3>{row.unfiltered[0], row.unfiltered[1], row.unfiltered[2]})
        << "}, \"tracking_mse_m2\": " << number(row.tracking_mse_m2) << "}";
  }
  out << "},\n";
  if (report.from_position) {
    const auto& position = report.position;
    out << "  \"from_position\": {\"mass_kg\": " << number(position.mass_kg)
        << ", \"validation_score\": " << number(report.position_validation_score)
        << ", \"mass_source\": " << yaml::quoted(report.position_mass_source)
        << ", \"payload_kg\": " << number(report.payload_kg) << ", \"payload_ratio\": " << number(report.payload_ratio)
        << ", \"knot_spacing_m\": " << number(position.knot_spacing_m) << ", \"spacing_scores\": [";
    for (std::size_t k = 0; k < position.spacing_scores.size(); ++k) {
      out << (k ? ", " : "") << "{\"knot_spacing_m\": " << number(position.spacing_scores[k].first)
          << ", \"held_out_balance_rms_N\": " << number(position.spacing_scores[k].second) << "}";
    }
    out << "], \"rows_from\": [";
    const auto& rows_from = position.model.provenance.rows_from;
    for (std::size_t q = 0; q < rows_from.size(); ++q) out << (q ? ", " : "") << yaml::quoted(name(rows_from[q]));
    out << "], \"coil_sets\": [";
    for (std::size_t l = 0; l < position.fits.size(); ++l) {
      const auto& fit = position.fits[l];
      out << (l ? ", " : "") << "{\"viscous_N_s_per_m\": " << number(fit.viscous_N_s_per_m)
          << ", \"direction_force_N\": " << number(fit.direction_N) << ", \"rows\": " << fit.rows
          << ", \"balance_rms_N\": " << number(fit.residual_rms_N)
          << ", \"held_out_balance_rms_N\": " << number(position.validation_residual_rms_N[l]) << "}";
    }
    out << "], \"calibration\": ";
    calibration_json(out, report.calibration_position);
    out << ", \"summary\": " << yaml::quoted(position_summary(report)) << "},\n";
  }
  out << "  \"step_wall_time_s\": {";
  for (std::size_t k = 0; k < report.steps.size(); ++k) {
    out << (k ? ", " : "") << yaml::quoted(report.steps[k].step) << ": " << number(report.steps[k].wall_s);
  }
  out << "},\n";
  if (report.live.live) {
    const LiveSummary& live = report.live;
    out << "  \"live\": {\"lcm_url\": " << yaml::quoted(live.lcm_url) << ", \"runs\": " << live.runs
        << ", \"runs_repeated\": " << live.runs_repeated << ", \"states_received\": " << live.states_received
        << ", \"states_recorded\": " << live.states_recorded << ", \"states_missing\": " << live.states_missing_kept
        << ", \"states_missing_in_repeated_runs\": " << live.states_missing_discarded
        << ", \"daemon_telemetry_dropped\": " << live.daemon_telemetry_dropped
        << ", \"status_fingerprint\": " << yaml::quoted(status_fingerprint_hex()) << "},\n";
  }
  out << "  \"total_wall_time_s\": " << number(report.total_wall_s) << "\n}\n";
  return out.str();
}

namespace {

// The verdict: the law, how it won, its margin, and what it gains over the
// calibrated classical law; then every competing law's score.
void verdict_markdown(std::ostringstream& out, const Report& report) {
  const data::Verdict& verdict = report.verdict;
  out << "## Verdict\n\n";
  out << "- law for service: **" << report.recommended << "**";
  if (report.decided_by == "no force sensor") {
    out << ", commissioned from positions (`--no-force-sensor`)";
    if (!report.force_recommended.empty()) out << "; the force-sensor laws alone would give " << report.force_recommended;
    out << "\n";
  } else {
    out << ", " << verdict_reason(verdict) << "\n";
  }
  const std::string margin = runner_up_margin(verdict);
  if (!margin.empty()) out << "- " << margin << "\n";
  const auto* reference = calibrated_classical(report);
  const auto* recommended = find(report, report.recommended);
  if (reference && recommended && recommended != reference) {
    const Improvement ratio = improvement(*reference, *recommended);
    out << "- over calibrated classical (" << reference->name << "): commutation MSE y "
        << fixed(ratio.force[0]) << "× lower, tracking MSE " << fixed(ratio.tracking) << "× lower (Fig. 8)\n";
  }
  if (!report.law_scores.empty()) {
    out << "\nValidation scores (Σ over coil sets of the held-out F_y MSE over the physics-only fit's; classical is "
           "the physics-only fit), with the standard error from the held-out blocks (docs/commutation.md, \"The "
           "recommendation\"), in the order of preference on a tie:\n\n"
           "| law | score | standard error | held-out blocks | − recommended (paired) | in standard errors |\n"
           "|---|---|---|---|---|---|\n";
    const auto* recommended_score = scored(report, report.recommended);
    for (const auto& entry : report.law_scores) {
      std::size_t blocks = 0;
      for (const auto& coil_set : entry.blocks) blocks += coil_set.size();
      out << "| " << entry.law << " | " << fixed(entry.score.value, "%.4g") << " | "
          << fixed(entry.score.standard_error, "%.2g") << " | " << blocks << " | ";
      if (recommended_score && recommended_score != &entry) {
        const data::ScoreEstimate d = data::score_difference(entry, *recommended_score);
        out << fixed(d.value, "%.3g") << " ± " << fixed(d.standard_error, "%.2g") << " | "
            << fixed(d.value / d.standard_error, "%.2g") << " |\n";
      } else {
        out << "– | – |\n";
      }
    }
  }
  out << "\n";
}

}  // namespace

std::string report_markdown(const Report& report) {
  std::ostringstream out;
  out << "# Commissioning report\n\n";
  out << "Configuration `" << report.config_path << "`, " << report.coil_sets << " coil sets, "
      << (report.live.live ? "a running clm-servod over LCM (" + report.live.lcm_url + "), its real-time clock"
                           : std::string("simulated motor, virtual clock"))
      << ". Experiments of calibration and identification: `" << report.experiment_program
      << "`. Every commutation is evaluated on `" << report.evaluation_program
      << "` (by default the paper's Fig. 8 reference: third-order moves between -0.1 and 0.1 m at 0.025, 0.075 and "
         "0.15 m/s, 1 m/s², 1000 m/s³) with its own identified feedforward (40).\n\n";
  if (!report.recommended.empty()) {
    out << "**Recommended for service: " << report.recommended << ".** " << report.recommendation << ".\n\n";
    verdict_markdown(out, report);
  }
  for (const auto& note : report.notes) out << "Note: " << note << ".\n\n";
  if (report.live.live) {
    const LiveSummary& live = report.live;
    out << "Live: " << live.runs << " runs, " << live.states_recorded << " program cycles recorded of "
        << live.states_received << " CLM_SERVO_STATE messages received; " << live.states_missing_kept
        << " missing in the runs kept, " << live.runs_repeated << " runs repeated after missing states ("
        << live.states_missing_discarded << " missing there); the daemon counted " << live.daemon_telemetry_dropped
        << " telemetry drops.\n\n";
  }
  out << "## Commutation error (paper Table 2 layout)\n\n";
  out << "MSE of the measured F − F*, low-pass filtered at 50 Hz (unfiltered in brackets), as the paper measures it. "
         "Paper values beside ours; the paper's PGNN row stands beside pgnn-paper, its 2/16-neuron network. The "
         "measured force contains the direction-dependent force and the sensor's bias and noise, which no static "
         "law acts on: a model that folded them into its gains can score below the oracle here while commanding "
         "a wrong force.\n\n";
  out << "| commutation | y [N²] | y paper | x [N²] | x paper | z [N²m²] | z paper | tracking [m²] | tracking paper |\n";
  out << "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : report.results) {
    if (!r.evaluated) {
      out << "| " << r.name << " | not evaluated: " << r.skipped_reason << " | | | | | | | |\n";
      continue;
    }
    const PaperRow* paper = nullptr;
    for (const auto& row : kPaper) {
      if (r.name == row.name || (r.name == "pgnn-paper" && std::string(row.name) == "pgnn")) paper = &row;
    }
    out << "| " << r.name;
    for (int q = 0; q < 3; ++q) {
      const auto i = static_cast<std::size_t>(q);
      out << " | " << fixed(r.mse.filtered[i]) << " (" << fixed(r.mse.unfiltered[i]) << ")";
      out << " | " << (paper ? fixed(paper->filtered[q]) + " (" + fixed(paper->unfiltered[q]) + ")" : std::string("–"));
    }
    out << " | " << fixed(r.tracking_mse_m2) << " | " << (paper ? fixed(paper->tracking_mse_m2) : std::string("–")) << " |\n";
  }
  const auto* oracle = find(report, "oracle");
  if (!report.results.empty() && report.results.front().truth_known) {
    out << "\n## True electromagnetic commutation error (simulation)\n\n"
           "True: MSE of the simulator's true electromagnetic wrench over each cycle's period − that cycle's F*, "
           "without the direction-dependent force and the sensor's bias and noise, filtered (unfiltered): the force "
           "the axis got against the one asked for, the drive's current loop and delay included. Static: what the "
           "law makes of each cycle's F* on the simulator's static truth at the true position, through an ideal "
           "drive, − F*: the law's own error, without the drive, the encoder and the cycle's timing. The oracle, "
           "the exact minimum-power inverse of the static truth, scores zero there up to rounding and the current "
           "limit; the ratio to it in tracking is the room a law leaves.\n\n"
           "| commutation | true y [N²] | true x [N²] | true z [N²m²] | static y [N²] | static x [N²] | static z [N²m²] "
           "| tracking [m²] | tracking / oracle |\n|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& r : report.results) {
      if (!r.evaluated || !r.truth_known) continue;
      out << "| " << r.name;
      for (const control::DirectionMse* mse : {&r.true_mse, &r.static_mse}) {
        for (std::size_t q = 0; q < 3; ++q) {
          out << " | " << fixed(mse->filtered[q]) << " (" << fixed(mse->unfiltered[q]) << ")";
        }
      }
      out << " | " << fixed(r.tracking_mse_m2) << " | "
          << (oracle ? fixed(r.tracking_mse_m2 / oracle->tracking_mse_m2, "%.2f") + "×" : std::string("–")) << " |\n";
    }
  }
  if (const auto* reference = calibrated_classical(report)) {
    // Every law evaluated, against the calibrated classical law of this run;
    // the paper's ratios beside its own 2/16 PGNN (pgnn-paper).
    out << "\n## Improvement over calibrated classical commutation\n\n"
        << reference->name << " over each law evaluated on `" << report.evaluation_program
        << "`: commutation MSE (filtered) and tracking MSE; above 1 the law is better.\n\n";
    out << "| law | y | x | z | tracking | paper y | paper tracking |\n|---|---|---|---|---|---|---|\n";
    for (const auto& r : report.results) {
      if (!r.evaluated || &r == reference) continue;
      const Improvement ratio = improvement(*reference, r);
      const bool paper = r.name == "pgnn-paper" && reference->name == "classical";
      out << "| " << r.name << (r.name == report.recommended ? " (recommended)" : "");
      for (std::size_t q = 0; q < 3; ++q) out << " | " << fixed(ratio.force[q]) << (std::isfinite(ratio.force[q]) ? "×" : "");
      out << " | " << fixed(ratio.tracking) << "× | " << (paper ? fixed(27.4 / 2.45) + "×" : "–") << " | "
          << (paper ? fixed(2.75e-8 / 5.94e-9) + "×" : "–") << " |\n";
    }
  }
  if (oracle) {
    out << "\nThe oracle is the exact minimum-power inverse of the simulator's static electromagnetic truth. On the "
           "true electromagnetic error it is exact up to the motion within one control period. On the measured force "
           "it leaves the direction-dependent force (paper Remark 5.1, compensated by the feedforward) and the "
           "sensor's bias and noise, so it is no limit there. Tracking MSE over the oracle's:";
    for (const auto& r : report.results) {
      if (r.evaluated && &r != oracle) out << " " << r.name << " " << fixed(r.tracking_mse_m2 / oracle->tracking_mse_m2, "%.2f") << "×;";
    }
    out << "\n";
    if (const std::string line = commutation_share_summary(report); !line.empty()) out << "\nThe " << line << ".\n";
  }
  if (const ErrorBudget& b = report.budget; b.computed) {
    out << "\n## Error budget (simulation)\n\nEach law's tracking MSE on the evaluation program, split by source "
           "as a dynamic error budget does: the oracle run again on the same plant with no error source (the loop "
           "through the plant's dynamics), with the force disturbance alone and with the encoder alone (its "
           "feedforward and the daemon as commissioned), each source as the oracle's increase; the commutation is "
           "the law's MSE over the oracle's, both with every source on. Uncorrelated sources through a linear loop "
           "add in MSE; what the parts do not add up to is their interaction. Shares of each law's tracking MSE:\n\n"
           "| commutation | tracking MSE [m²] | loop | force disturbance | encoder | commutation | sum of the parts "
           "|\n|---|---|---|---|---|---|---|\n";
    for (const auto& r : report.results) {
      const std::optional<LawBudget> law = law_budget(report, r.name);
      if (!law || !(law->whole_m2 > 0.0)) continue;
      out << "| " << law->law << " | " << fixed(law->whole_m2);
      for (const auto& [name, value] : budget_parts(b, *law)) out << " | " << percent_of(value, law->whole_m2);
      out << " | " << percent_of(law->sum_m2, law->whole_m2) << " |\n";
    }
  }
  if (!report.validation.empty()) {
    out << "\n## Held-out trajectory\n\nThe same commutations and feedforwards on `" << report.validation_program
        << "`, a trajectory used for neither identification nor feedforward fitting (true y and static y as in "
           "\"True electromagnetic commutation error\", in simulation).\n\n"
           "| commutation | y [N²] | x [N²] | z [N²m²] | true y [N²] | static y [N²] | tracking [m²] |\n"
           "|---|---|---|---|---|---|---|\n";
    for (const auto& r : report.validation) {
      if (!r.evaluated) continue;
      out << "| " << r.name;
      for (std::size_t q = 0; q < 3; ++q) out << " | " << fixed(r.mse.filtered[q]) << " (" << fixed(r.mse.unfiltered[q]) << ")";
      out << " | " << (r.truth_known ? fixed(r.true_mse.filtered[0]) : std::string("–")) << " | "
          << (r.truth_known ? fixed(r.static_mse.filtered[0]) : std::string("–")) << " | " << fixed(r.tracking_mse_m2)
          << " |\n";
    }
  }
  out << "\n## Calibration (Algorithm 1)\n\n| coil set | k̂ [N/A] | ζ̂ [rad] | k̂ robust | ζ̂ robust | paper k̂ | paper ζ̂ |\n|---|---|---|---|---|---|---|\n";
  const double paper_k[] = {61.34, 61.62, 60.07};
  const double paper_zeta[] = {-0.54, -0.55, -0.55};
  for (std::size_t l = 0; l < report.calibration_paper.coil_sets.size(); ++l) {
    const auto& a = report.calibration_paper.coil_sets[l].estimate;
    const auto& b = report.calibration_robust.coil_sets[l].estimate;
    out << "| " << l + 1 << " | " << fixed(a.motor_constant_N_per_A, "%.2f") << " | " << fixed(a.phase_offset_rad, "%.3f")
        << " | " << fixed(b.motor_constant_N_per_A, "%.2f") << " | " << fixed(b.phase_offset_rad, "%.3f") << " | "
        << (l < 3 ? fixed(paper_k[l], "%.2f") : "–") << " | " << (l < 3 ? fixed(paper_zeta[l], "%.2f") : "–") << " |\n";
  }
  const auto identification = [&](const char* title, const std::vector<data::CoilSetIdentification>& entries) {
    out << "\n## Identification: " << title << "\n\nData-term cost (mean squared error) per direction y/x/z, physics-only "
           "model vs identified model, fit on the training data, on them and on held-out validation data; then the "
           "model put to use, fit on every sample (docs/commutation.md, \"Identification\").\n\n"
           "The last two columns: the condition of the column-scaled regressors the model is linear in, on the data "
           "it was fit on, the directions it cannot tell apart, the parameters the data leave unexcited, and what the data lack along the stroke "
           "(docs/commutation.md, \"Fit quality\").\n\n"
           "| coil set | physics train | model train | physics valid | model valid | physics all | model put to use, all "
           "| Prop. 4.1 | regressor condition (dependent, unexcited) | excitation |\n|---|---|---|---|---|---|---|---|---|---|\n";
    for (std::size_t l = 0; l < entries.size(); ++l) {
      const auto& r = entries[l].report;
      const auto cell = [&](const identification::DirectionCost& c) {
        return fixed(c[0]) + " / " + fixed(c[1]) + " / " + fixed(c[2]);
      };
      out << "| " << l + 1 << " | " << cell(r.physics_training) << " | " << cell(r.model_training) << " | "
          << cell(r.physics_validation) << " | " << cell(r.model_validation) << " | " << cell(r.physics_fit)
          << " | " << cell(r.model_fit) << " | "
          << ((r.proposition_holds[0] && r.proposition_holds[1] && r.proposition_holds[2]) ? "holds" : "violated")
          << " | " << fixed(r.regressors.condition, "%.3g") << " (" << r.regressors.dependent << " dependent, "
          << r.regressors.unexcited << " unexcited of " << r.regressors.parameters << ") | ";
      if (r.excitation_gaps.empty()) out << "every stretch excited";
      for (std::size_t g = 0; g < r.excitation_gaps.size(); ++g) {
        const auto& gap = r.excitation_gaps[g];
        out << (g ? "; " : "") << identification::describe(gap.lack) << " in [" << fixed(gap.low_m, "%.4g") << ", "
            << fixed(gap.high_m, "%.4g") << "] m";
      }
      out << " |\n";
    }
  };
  identification("PGNN", report.pgnn);
  identification("spline", report.spline);
  const auto selection = [&](const char* title, const data::IdentifySummary& summary) {
    out << "\n## Capacity and nuisance terms: " << title << "\n\n";
    if (summary.nuisance) {
      const auto& o = summary.sensor_offset;
      out << "Sensor offset in y from the mechanics (F_y = m·ÿ + f_v·ẏ + f_c·tanh(ẏ/v_s) + offset over every "
             "experiment sample): **"
          << fixed(o.offset_N, "%.3f") << " N**, removed from the data (m " << fixed(o.mass_kg, "%.2f") << " kg, f_v "
          << fixed(o.viscous_N_s_per_m, "%.1f") << " N·s/m, f_c " << fixed(o.coulomb_N, "%.2f") << " N, residual RMS "
          << fixed(o.residual_rms_N, "%.2f") << " N, condition " << fixed(o.condition, "%.1f")
          << "). The x and z offsets are not observable: the guides carry those forces.\n\n"
             "Direction-dependent force: variance inflation "
          << fixed(summary.direction_force_inflation, "%.3g") << " (identified up to "
          << fixed(identification::kMaxDirectionForceInflation, "%.3g") << ").";
      if (summary.direction_force) {
        out << " v_c of C·tanh(ẏ/v_c), by the spline's validation score:";
        for (const auto& [velocity, score] : summary.direction_smoothing_scores) {
          out << " " << fixed(velocity * 1e3, "%.2g") << " mm/s " << fixed(score, "%.4g") << ";";
        }
      } else {
        out << " " << summary.direction_force_skipped << ".";
      }
      out << "\n\n";
    } else if (!summary.nuisance_skipped.empty()) {
      out << "Nuisance terms not identified: " << summary.nuisance_skipped << ".\n\n";
    }
    out << "| capacity | validation score | chosen | C per coil set [N, N, N·m] |\n|---|---|---|---|\n";
    for (std::size_t k = 0; k < summary.trials.size(); ++k) {
      const auto& trial = summary.trials[k];
      out << "| " << trial.capacity << " | " << fixed(trial.validation_score, "%.4g") << " | "
          << (k == summary.chosen ? "yes" : "") << " |";
      for (const auto& entry : trial.coil_sets) {
        const auto& c = entry.report.direction_force.amplitude;
        out << " [" << fixed(c[0], "%.2f") << ", " << fixed(c[1], "%.2f") << ", " << fixed(c[2], "%.2f") << "]";
      }
      out << " |\n";
    }
  };
  selection("PGNN", report.pgnn_selection);
  selection("spline", report.spline_selection);
  if (report.from_position) {
    const auto& position = report.position;
    const bool off_axis_from_forces = position.model.provenance.rows_from[1] == RowSource::kForceSensor;
    out << "\n## From positions\n\nThe same experiments without their force columns "
           "(`experiments-position.csv`): the F_y rows of every coil set identified from positions and times jointly "
           "with the mechanics (docs/commutation.md, \"Without a force sensor\"); "
        << (off_axis_from_forces ? "F_x and T_z rows the force-sensor spline's, on its knot grid"
                                 : "F_x and T_z rows zero, from the drive's constants")
        << ". classical-position is Algorithm 1 on the driving force that model reconstructs.\n\n"
        << position_summary(report) << ".\n\n";
    out << "Mass " << fixed(position.mass_kg, "%.4g") << " kg (" << report.position_mass_source
        << "; without a mass, the scale that brings A_y, B_y closest to the drive's nominal commutation); knots every " << fixed(position.knot_spacing_m * 1e3) << " mm";
    if (!position.spacing_scores.empty()) {
      out << " (held-out force balance RMS:";
      for (const auto& [spacing, score] : position.spacing_scores) {
        out << " " << fixed(spacing * 1e3) << " mm " << fixed(score, "%.4g") << " N;";
      }
      out << ")";
    }
    out << ".\n\n| coil set | f_v [N s/m] | f_d [N] | rows | balance RMS [N] | held-out RMS [N] | k̂ [N/A] | ζ̂ [rad] |\n"
           "|---|---|---|---|---|---|---|---|\n";
    for (std::size_t l = 0; l < position.fits.size(); ++l) {
      const auto& fit = position.fits[l];
      out << "| " << l + 1 << " | " << fixed(fit.viscous_N_s_per_m, "%.4g") << " | " << fixed(fit.direction_N, "%.4g")
          << " | " << fit.rows << " | " << fixed(fit.residual_rms_N, "%.4g") << " | "
          << fixed(position.validation_residual_rms_N[l], "%.4g") << " | ";
      if (l < report.calibration_position.coil_sets.size()) {
        const auto& estimate = report.calibration_position.coil_sets[l].estimate;
        out << fixed(estimate.motor_constant_N_per_A, "%.4g") << " | " << fixed(estimate.phase_offset_rad, "%.4f");
      } else {
        out << "– | –";
      }
      out << " |\n";
    }
  }
  out << "\n## Wall time\n\n| step | s |\n|---|---|\n";
  for (const auto& step : report.steps) out << "| " << step.step << " | " << fixed(step.wall_s, "%.1f") << " |\n";
  out << "| total | " << fixed(report.total_wall_s, "%.1f") << " |\n";
  // The PNGs tools/commission/plot_report.py draws from these files; what
  // each answers is in docs/report-format.md, "Plots".
  out << "\n## Plots\n\nWhat each plot answers and what to look for: docs/report-format.md, \"Plots\".\n\n";
  std::vector<std::string> plots{"calibration.png", "commutation-error-slow.png", "commutation-error-fast.png",
                                 "position-error.png", "tracking-error.png", "tracking-psd.png"};
  if (!report.validation.empty()) plots.push_back("validation.png");
  if (std::find(report.files.begin(), report.files.end(), "truth-comparison.csv") != report.files.end()) {
    plots.insert(plots.end(), {"cogging.png", "cogging-error.png", "gain.png", "gain-error.png"});
  }
  if (report.live.live) plots.push_back("latency.png");  // the loop's timing means something on a real-time clock only
  for (const auto& plot : plots) out << "![" << plot << "](" << plot << ")\n";
  return out.str();
}

}  // namespace clm::commission
