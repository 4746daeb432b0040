#include "tools/commission/commission.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <cmath>
#include <filesystem>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <mutex>
#include <thread>
#include <exception>
#include <memory>

#include "config/atomic_file.hpp"
#include "drivers/sim/parameters.hpp"
#include "config/sha256.hpp"
#include "daemon/servod/feedforward_file.hpp"
#include "daemon/servod/file_policy.hpp"
#include "drivers/sim/motor.hpp"
#include "tools/commission/live_runner.hpp"
#include "tools/commission/preflight.hpp"
#include "tools/commission/progress.hpp"
#include "tools/data/csv_table.hpp"

namespace clm::commission {

IncompleteMarker::IncompleteMarker(const std::string& dir, const std::string& stage)
    : path_(dir + "/" + kIncompleteMarker) {
  write_file_atomically(path_, "clm commission has not finished " + stage +
                                   " in this directory: its files may be partial or from an earlier run. The "
                                   "finished stage removes this file.\n");
}

void IncompleteMarker::finished() { std::filesystem::remove(path_); }
namespace {

/// The experiments written to `csv`, in the frame of the axis they ran on.
data::ExperimentData read_experiments(const std::string& csv, const MotorDescription& motor, const Report& report) {
  data::ExperimentData data = data::read_experiment_data(data::CsvTable::load(csv), motor);
  data.reference = report.encoder_reference;
  return data;
}

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Experiment rows of the recordings, in the tools' CSV format. With a
// phase-current drive the currents the daemon sent (ia_A, ib_A of the
// record) are the data; with magnitude_phase they are left out and
// reconstructed from the setpoints through the drive's fixed commutation.
// Without `forces` the force columns are left out, as an axis without a
// force sensor records them.
void write_experiment_csv(const std::string& path, const std::vector<Recording>& runs, DriveProfile profile,
                          bool forces) {
  std::vector<std::string> names = {"t_s", "coil_set", "delta_rad", "magnitude_N", "y_m", "Fy_N", "Fx_N", "Tz_Nm",
                                    "ia_A", "ib_A"};
  std::vector<bool> keep = {true, true, true, true, true, forces, forces, forces,
                            profile == DriveProfile::kPhaseCurrent, profile == DriveProfile::kPhaseCurrent};
  std::vector<std::vector<double>> columns(names.size());
  double offset_s = 0.0;
  for (const auto& run : runs) {
    for (const auto& s : run.samples) {
      // The states say what went to the drive; a daemon whose drive profile
      // is not the configuration's made data this step would misread.
      if (s.drive_profile != profile) {
        throw std::runtime_error(std::string("experiments: the daemon sent ") + name(s.drive_profile) +
                                 " setpoints in cycle " + std::to_string(s.cycle) + ", but the motor file says " +
                                 "drive.profile " + name(profile));
      }
      const auto l = static_cast<std::size_t>(s.coil_set - 1);
      const double row[] = {offset_s + s.program_time_s, static_cast<double>(s.coil_set), s.delta_rad,
                            s.magnitude_N[l], s.y_m, s.Fy_N, s.Fx_N, s.Tz_Nm, s.ia_A[l], s.ib_A[l]};
      for (std::size_t c = 0; c < names.size(); ++c) columns[c].push_back(row[c]);
    }
    if (!run.samples.empty()) offset_s += run.samples.back().program_time_s + 1.0;
  }
  std::vector<std::string> kept_names;
  std::vector<std::vector<double>> kept_columns;
  for (std::size_t c = 0; c < names.size(); ++c) {
    if (!keep[c]) continue;
    kept_names.push_back(names[c]);
    kept_columns.push_back(std::move(columns[c]));
  }
  data::write_csv_atomically(path, kept_names, kept_columns);
}

void write_feedforward_csv(const std::string& path, const Recording& run) {
  const std::vector<std::string> names = {"t_s", "r_m", "F_star_N"};
  std::vector<std::vector<double>> columns(3);
  for (const auto& s : run.samples) {
    columns[0].push_back(s.program_time_s);
    columns[1].push_back(s.r_m);
    columns[2].push_back(s.F_star_N);
  }
  data::write_csv_atomically(path, names, columns);
}

void write_evaluation_csv(const std::string& path, const Recording& run, const control::MoveProgram& program) {
  const std::vector<std::string> names = {"t_s", "step", "r_m", "y_m", "e_m", "F_star_N", "u_ff_N", "Fy_star_N",
                                          "Fy_N", "Fx_N", "Tz_Nm", "current_square_sum_A2"};
  std::vector<std::vector<double>> columns(names.size());
  std::size_t step = 0;
  for (const auto& s : run.samples) {
    while (step + 1 < program.steps().size() && s.program_time_s >= program.step_start_s(step + 1)) ++step;
    const double row[] = {s.program_time_s, static_cast<double>(step), s.r_m, s.y_m, s.r_m - s.y_m, s.F_star_N,
                          s.u_ff_N, s.Fy_star_N, s.Fy_N, s.Fx_N, s.Tz_Nm, s.current_square_sum_A2};
    for (std::size_t c = 0; c < names.size(); ++c) columns[c].push_back(row[c]);
  }
  data::write_csv_atomically(path, names, columns);
}

// Identified against true cogging and gains on a position grid (Fig. 9).
void write_truth_comparison(const std::string& directory, const sim::SimulatedMotor& motor, const ModelFile& pgnn,
                            const ModelFile& spline, const MotorDescription& description) {
  std::vector<std::string> names = {"y_m"};
  for (const char* who : {"true", "pgnn", "spline"}) {
    for (const char* axis : {"Fy_N", "Fx_N", "Tz_Nm"}) names.push_back(std::string("cogging_") + who + "_" + axis);
  }
  for (int l = 1; l <= description.coil_sets; ++l) {
    for (const char* who : {"true", "pgnn", "spline"}) {
      for (const char* entry : {"Kya", "Kyb", "Kxa", "Kxb", "Kza", "Kzb"}) {
        names.push_back(std::string(entry) + "_" + who + "_" + std::to_string(l));
      }
    }
  }
  std::vector<std::vector<double>> columns(names.size());
  const ModelFile* models[2] = {&pgnn, &spline};
  for (double y = description.stroke_min_m; y <= description.stroke_max_m + 1e-12; y += 2.5e-4) {
    std::size_t c = 0;
    columns[c++].push_back(y);
    const Wrench truth = motor.true_cogging(y);
    for (int k = 0; k < 3; ++k) columns[c++].push_back(truth[k]);
    for (const ModelFile* model : models) {
      StackedGain gain;
      Wrench cogging;
      model->model.evaluate(y, gain, cogging);
      for (int k = 0; k < 3; ++k) columns[c++].push_back(cogging[k]);
    }
    for (int l = 0; l < description.coil_sets; ++l) {
      const CoilGain true_gain = motor.true_gain(l, y);
      for (int k = 0; k < 6; ++k) columns[c++].push_back(true_gain(k / 2, k % 2));
      for (const ModelFile* model : models) {
        CoilGain gain;
        Wrench cogging;
        model->model.evaluate_coil_set(l, y, gain, cogging);
        for (int k = 0; k < 6; ++k) columns[c++].push_back(gain(k / 2, k % 2));
      }
    }
  }
  data::write_csv_atomically(directory + "/truth-comparison.csv", names, columns);
}

// Writes a file into the output directory (recorded in the report) and
// returns its absolute path; reports a step's progress.
using WrittenFile = std::function<std::string(const std::string&)>;
using Tell = std::function<void(const std::string&, double, const std::string&)>;

// Step 2 with the force sensor: Algorithm 1 and its offset-robust variant,
// the PGNN and spline identification. Returns the experiment data.
data::ExperimentData identify_from_forces(const Options& options, const MotorDescription& motor,
                                          const std::vector<Recording>& experiments, const WrittenFile& written,
                                          const Tell& tell, Report& report, ModelFile (&models)[2],
                                          bool& paper_is_chosen) {
  const std::string experiment_csv = written("experiments.csv");
  write_experiment_csv(experiment_csv, experiments, motor.drive_profile, true);
  auto step_start = Clock::now();
  data::ExperimentData data = read_experiments(experiment_csv, motor, report);
  const std::string data_hash = sha256_file(experiment_csv);
  report.calibration_paper = data::calibrate_motor(data, motor, data::CalibrationMethod::kAlgorithm1);
  report.calibration_robust = data::calibrate_motor(data, motor, data::CalibrationMethod::kOffsetRobust);
  for (CalibrationFile* file : {&report.calibration_paper, &report.calibration_robust}) {
    file->data_sha256 = data_hash;
    file->generator = "clm commission";
  }
  write_file_atomically(written("calibration.yaml"), format_calibration_file(report.calibration_paper));
  write_file_atomically(written("calibration-robust.yaml"), format_calibration_file(report.calibration_robust));
  report.steps.push_back({"calibration", seconds_since(step_start)});

  for (int k = 0; k < 2; ++k) {
    step_start = Clock::now();
    data::IdentifyOptions identify = options.identify;
    identify.kind = k == 0 ? ModelKind::kPgnn : ModelKind::kSpline;
    const std::string label = k == 0 ? "identify pgnn" : "identify spline";
    auto& reports = k == 0 ? report.pgnn : report.spline;
    auto& selection = k == 0 ? report.pgnn_selection : report.spline_selection;
    models[k] = data::identify_motor(data, motor, identify, reports, [&](const data::IdentifyProgress& p) {
      tell(label, p.fraction(), p.what);
    }, &selection);
    for (auto& trial : selection.trials) {
      trial.model.provenance.data_sha256 = data_hash;
      trial.model.provenance.generator = "clm commission";
    }
    models[k].provenance.data_sha256 = data_hash;
    models[k].provenance.generator = "clm commission";
    write_file_atomically(written(k == 0 ? "model-pgnn.yaml" : "model-spline.yaml"), format_model_file(models[k]));
    report.steps.push_back({label, seconds_since(step_start)});
  }
  // The paper's PGNN (2/16 neurons) is always evaluated, for Table 2.
  const data::CapacityTrial* paper_pgnn = nullptr;
  for (const auto& trial : report.pgnn_selection.trials) {
    if (trial.is_paper_pgnn()) paper_pgnn = &trial;
  }
  paper_is_chosen =
      paper_pgnn == nullptr || paper_pgnn == &report.pgnn_selection.trials[report.pgnn_selection.chosen];
  if (paper_pgnn != nullptr) {
    write_file_atomically(written("model-pgnn-paper.yaml"), format_model_file(paper_pgnn->model));
  }
  return data;
}

// Step 2 from positions (docs/commissioning.md, "Without a force sensor"):
// the experiments without their force columns, the spline model and
// Algorithm 1 on the force it reconstructs. Beside the force models
// (`force_spline`) the mass that sets the scale is their mechanics fit's and
// the F_x and T_z rows are the force spline's, on its knot grid; else the
// mass is the configuration's or --mass-kg, or the payload experiments'
// (`payload_experiments` not empty), and those rows are zero.
void identify_from_positions(const Options& options, const servod::ServodConfig& config,
                             const std::vector<Recording>& experiments,
                             const std::vector<Recording>& payload_experiments, const WrittenFile& written,
                             const Tell& tell, const ModelFile* force_spline,
                             const data::ExperimentData* force_data, Report& report) {
  const MotorDescription& motor = config.motor;
  auto step_start = Clock::now();
  tell("identify from positions", 0.0, "");
  const std::string position_csv = written("experiments-position.csv");
  write_experiment_csv(position_csv, experiments, motor.drive_profile, false);
  data::ExperimentData position_data = read_experiments(position_csv, motor, report);
  report.from_position = true;
  data::PositionIdentifyOptions position = options.position;
  if (force_spline != nullptr) {
    position.motion.mass_kg = report.spline_selection.sensor_offset.mass_kg;  // sets the scale: no friction prior
    position.motion.viscous_N_s_per_m = position.motion.direction_N = 0.0;
    position.basis = force_spline->model.spline_basis;
    report.position_mass_source = "the force sensor's mechanics fit";
  } else if (!payload_experiments.empty()) {
    const std::string payload_csv = written("experiments-payload.csv");
    write_experiment_csv(payload_csv, payload_experiments, motor.drive_profile, false);
    const data::ExperimentData payload_data = read_experiments(payload_csv, motor, report);
    const identification::PayloadMass found =
        data::mass_from_payload(position_data, payload_data, motor, position, options.payload_kg);
    position.motion.mass_kg = found.mass_kg;
    position.motion.viscous_N_s_per_m = position.motion.direction_N = 0.0;
    report.payload_kg = options.payload_kg;
    report.payload_ratio = found.ratio;
    char source[96];
    std::snprintf(source, sizeof(source), "the experiments with a payload of %.6g kg", options.payload_kg);
    report.position_mass_source = source;
  } else {
    if (options.mass_from_config) position.motion.mass_kg = config.control_mass_kg;
    using Scale = identification::MotionFitOptions::Scale;
    const Scale scale = position.motion.scale();
    report.position_mass_source = scale == Scale::kMass       ? (options.mass_from_config
                                                                   ? "control.mass_kg of the configuration"
                                                                   : "--mass-kg")
                                  : scale == Scale::kFriction ? "the friction given"
                                                              : "none: the scale of the drive's nominal commutation";
  }
  report.position = data::identify_from_position(position_data, motor, position);
  ModelFile& model = report.position.model;
  if (force_spline != nullptr) data::take_off_axis_rows(model, *force_spline);
  model.provenance.data_sha256 = sha256_file(position_csv);
  model.provenance.generator = "clm commission";
  write_file_atomically(written("model-spline-position.yaml"), format_model_file(model));
  if (force_spline != nullptr && force_data != nullptr) {
    // Scored as the force models are: fit without the force data's held-out
    // rows, so that its held-out score is one (docs/commutation.md, "The
    // recommendation").
    const ElectromagneticModel without = data::position_model_without(
        position_data, motor, position, report.position,
        data::held_out_times(*force_data, options.identify.validation_fraction));
    report.position_validation_score = data::position_validation_score(
        *force_data, options.identify, report.spline_selection, report.spline, without, &report.position_held_out);
  }
  report.steps.push_back({"identify from positions", seconds_since(step_start)});
  step_start = Clock::now();
  data::reconstruct_driving_force(position_data, motor, report.position);
  report.calibration_position = data::calibrate_motor(position_data, motor, data::CalibrationMethod::kPosition);
  report.calibration_position.data_sha256 = model.provenance.data_sha256;
  report.calibration_position.generator = "clm commission";
  write_file_atomically(written("calibration-position.yaml"), format_calibration_file(report.calibration_position));
  report.steps.push_back({"calibration from positions", seconds_since(step_start)});
}

}  // namespace

control::FeedforwardParameters identify_ff(const Recording& run) {
  std::vector<control::ReferenceSample> reference;
  std::vector<double> force;
  reference.reserve(run.samples.size());
  for (const auto& s : run.samples) {
    reference.push_back({s.r_m, s.r_dot_m_per_s, s.r_ddot_m_per_s2, 0.0});
    force.push_back(s.F_star_N);
  }
  return control::identify_feedforward(reference, force);
}

control::TrackingSplit split_tracking(const Recording& run, const servod::ServodConfig& config) {
  std::vector<double> position, feedforward, tracking_error;
  for (const auto& s : run.samples) {
    position.push_back(s.y_m);
    feedforward.push_back(s.u_ff_N);
    tracking_error.push_back(s.r_m - s.y_m);
  }
  try {
    return control::split_tracking_error(position, feedforward, tracking_error, config.motor.pole_pitch_m,
                                         config.servo.pid, config.control_mass_kg, config.servo.period_s);
  } catch (const std::invalid_argument&) {
    return {};  // too short a run: fewer than four samples per regressor
  }
}

CommutationResult evaluate(const Recording& run, double period_s) {
  CommutationResult result;
  std::vector<Eigen::Vector3d> measured, desired;
  double tracking = 0.0, current = 0.0;
  for (const auto& s : run.samples) {
    measured.emplace_back(s.Fy_N, s.Fx_N, s.Tz_Nm);
    desired.emplace_back(s.Fy_star_N, s.Fx_star_N, s.Tz_star_Nm);
    tracking += (s.r_m - s.y_m) * (s.r_m - s.y_m);
    current += s.current_square_sum_A2;
  }
  const double n = static_cast<double>(run.samples.size());
  result.mse = control::commutation_error_mse(measured, desired, period_s);
  // An axis without a force sensor measured nothing to compare with.
  const bool forces =
      std::any_of(run.samples.begin(), run.samples.end(), [](const auto& s) { return s.force_measured; });
  if (!forces) {
    constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
    result.mse.filtered = result.mse.unfiltered = {kNone, kNone, kNone};
  }
  if (!run.samples.empty() && run.true_wrench.size() == run.samples.size() &&
      run.static_wrench.size() == run.samples.size()) {
    result.true_mse = control::commutation_error_mse(run.true_wrench, desired, period_s);
    result.static_mse = control::commutation_error_mse(run.static_wrench, desired, period_s);
    result.truth_known = true;
  }
  result.tracking_mse_m2 = tracking / n;
  result.mean_current_square_A2 = current / n;
  result.damping_cycles = run.damping_cycles;
  result.force_limited_cycles = run.force_limited_cycles;
  result.evaluated = true;
  return result;
}

std::optional<LawBudget> law_budget(const Report& report, const std::string& law) {
  if (!report.budget.computed) return std::nullopt;
  const CommutationResult *result = nullptr, *oracle = nullptr;
  for (const auto& r : report.results) {
    if (!r.evaluated) continue;
    if (r.name == law) result = &r;
    if (r.name == "oracle") oracle = &r;
  }
  if (result == nullptr || oracle == nullptr) return std::nullopt;
  const ErrorBudget& b = report.budget;
  LawBudget budget{law, result->tracking_mse_m2, result->tracking_mse_m2 - oracle->tracking_mse_m2, 0.0};
  budget.sum_m2 = b.loop_m2 + b.disturbance_m2 + b.encoder_m2 + budget.commutation_m2;
  return budget;
}

namespace {

// "0.119 ± 0.0021" with the precision of the figures it is compared with.
std::string with_error(const data::ScoreEstimate& score) {
  char text[64];
  if (std::isfinite(score.standard_error)) {
    std::snprintf(text, sizeof(text), "%.4g ± %.2g", score.value, score.standard_error);
  } else {
    std::snprintf(text, sizeof(text), "%.4g (no standard error: nothing held out)", score.value);
  }
  return text;
}

// The laws' scores in kTieOrder: the physics-only fit as "classical", then
// those of `candidates` ("spline", "spline-position", "pgnn") that exist.
std::vector<data::LawScore> laws_in_tie_order(const Report& report, bool with_position) {
  std::vector<data::LawScore> laws;
  const auto from_trial = [](const char* law, const data::IdentifySummary& s) {
    const data::CapacityTrial& trial = s.trials[s.chosen];
    if (!trial.held_out.empty()) return data::law_score(law, trial.held_out);
    return data::LawScore{law, {}, {trial.validation_score, std::numeric_limits<double>::quiet_NaN()}};
  };
  for (const char* law : kTieOrder) {
    const std::string name = law;
    if (report.refused_laws.count(name) != 0) continue;
    if (name == "spline" && !report.spline_selection.trials.empty()) {
      laws.push_back(from_trial(law, report.spline_selection));
    } else if (name == "pgnn" && !report.pgnn_selection.trials.empty()) {
      laws.push_back(from_trial(law, report.pgnn_selection));
    } else if (name == "spline-position" && with_position && std::isfinite(report.position_validation_score)) {
      if (!report.position_held_out.empty()) {
        laws.push_back(data::law_score(law, report.position_held_out));
      } else {
        laws.push_back({law, {}, {report.position_validation_score, std::numeric_limits<double>::quiet_NaN()}});
      }
    }
  }
  // The physics-only fit scores 1 per coil set; its blocks are any law's
  // physics errors (z = 0 in them, so that its paired difference with a law
  // has that law's own standard error).
  data::LawScore physics{"classical", {}, {1.0 * report.coil_sets, 0.0}};
  for (const auto& law : laws) {
    if (!law.blocks.empty()) {
      physics = data::law_score("classical", data::physics_only(law.blocks));
      break;
    }
  }
  laws.insert(laws.begin(), physics);
  return laws;
}

}  // namespace

void recommend(Report& report) {
  report.law_scores = laws_in_tie_order(report, true);
  const data::Verdict forces = data::choose_law(laws_in_tie_order(report, false));
  report.force_recommended = forces.recommended;
  report.verdict = data::choose_law(report.law_scores);
  const data::Verdict& verdict = report.verdict;
  report.recommended = verdict.recommended;
  report.decided_by = verdict.tie ? "tie rule" : "validation score";

  const auto name_of = [](const data::IdentifySummary& s) { return s.trials[s.chosen].capacity; };
  std::string text =
      "validation score (sum over coil sets of the model's held-out F_y MSE over the physics-only fit's, ± its "
      "standard error from the held-out blocks):";
  for (const auto& entry : report.law_scores) {
    text += " " + entry.law;
    if (entry.law == "spline") text += " (" + name_of(report.spline_selection) + ")";
    if (entry.law == "pgnn") text += " (" + name_of(report.pgnn_selection) + ")";
    if (entry.law == "spline-position") text += " (mass from " + report.position_mass_source + ")";
    if (entry.law == "classical") text += " (physics-only fit)";
    text += " " + with_error(entry.score) + ";";
  }
  text.pop_back();
  for (const auto& [law, why] : report.refused_laws) text += "; " + law + " not a candidate, clm-servod refuses it: " + why;
  text += "; " + verdict.recommended + ", " + verdict_reason(verdict);
  const std::string margin = runner_up_margin(verdict);
  if (!margin.empty()) text += "; " + margin;
  report.recommendation = text;
}

std::string verdict_reason(const data::Verdict& verdict) {
  char k[16];
  std::snprintf(k, sizeof(k), "%g", data::kTieStandardErrors);
  if (verdict.recommended == "classical") {
    return std::string("as no model beats the physics-only fit by more than ") + k +
           " standard errors of their paired difference: keep the calibrated classical law";
  }
  if (verdict.tie) {
    std::string tied;
    for (const auto& law : verdict.tied) tied += (tied.empty() ? "" : ", ") + law;
    std::string order;
    for (const char* law : kTieOrder) order += (order.empty() ? "" : ", ") + std::string(law);
    return "by the tie rule: " + tied + " score within " + k +
           " standard errors of the paired difference of the lowest: a tie, broken by the order of preference (" +
           order + ")";
  }
  return std::string("a clear win: its validation score is the lowest by more than ") + k +
         " standard errors of the paired difference";
}

std::string runner_up_margin(const data::Verdict& verdict) {
  if (verdict.runner_up.empty()) return "";
  // Negative when the tie rule chose a law that scores higher than the runner-up.
  char margin[200];
  std::snprintf(margin, sizeof(margin),
                "%s, the runner-up, scores %.3g %s (%.2g standard errors of the paired difference)",
                verdict.runner_up.c_str(), std::abs(verdict.margin_score), verdict.margin_score < 0.0 ? "lower" : "higher",
                std::abs(verdict.margin_standard_errors));
  return margin;
}

namespace {

/// Calibration and identification measure forces (docs/bring-up.md:
/// commissioning with a borrowed sensor), or positions alone when asked.
void check_force_sensor(const servod::ServodConfig& config, const Options& options) {
  if (!can::has_force_sensor(config.servo.protocol) && !options.no_force_sensor) {
    throw std::runtime_error(options.config_path + ": can.force_sensor_node_id: absent, so the axis has no force "
                             "sensor; commissioning measures forces: mount one and name its node, or commission from "
                             "positions alone with --no-force-sensor");
  }
}

}  // namespace

std::string payload_refusal(const Options& options) {
  if (options.payload_kg == 0.0) return "";
  const auto& motion = options.position.motion;
  if (options.no_force_sensor && options.payload_kg > 0.0 && std::isfinite(options.payload_kg) &&
      motion.scale() == identification::MotionFitOptions::Scale::kNominal) {
    return "";
  }
  return "--payload-kg " + yaml::format_double(options.payload_kg) +
         ": a payload gives the mass of the commissioning from positions; it needs --no-force-sensor, a positive "
         "finite mass, and neither --mass-kg nor a friction";
}

Report run(const Options& options, const std::function<void(const Progress&)>& progress) {
  const servod::ServodConfig config = servod::load_servod_config(options.config_path);
  check_force_sensor(config, options);  // before anything live is touched
  if (options.live) {
    // Everything that could fail late is checked now, before the first
    // experiment (preflight.hpp): --out, the programs, the daemon, timing.
    // --out first, before anything is opened: it needs no daemon.
    const std::string out_refusal =
        servod::check_output_directory({config.commands.file_directories, config.commands.max_file_bytes}, options.out_dir);
    if (!out_refusal.empty()) throw std::runtime_error(describe_refusals({"--out " + out_refusal}));
    LiveOptions live = options.live_options;
    if (live.lcm_url.empty()) live.lcm_url = servod_client::lcm_url_or(config.telemetry.lcm_url);
    LcmRunner runner(config, live);
    const DaemonView daemon = runner.observe();
    const std::vector<std::string> refusals = live_preflight(config, options, daemon);
    if (!refusals.empty()) throw std::runtime_error(describe_refusals(refusals));
    Options with_identity = options;
    with_identity.identity = run_identity(daemon.status, program_paths(options).experiment);
    Report report = run(with_identity, runner, progress);
    return report;
  }
  if (options.resume) {
    throw std::runtime_error("--resume: only a live commissioning (--live) resumes; in process it runs whole");
  }
  if (config.can.bus != servod::BusKind::kSimulated) {
    throw std::runtime_error(options.config_path + ": can.interface: commissioning runs against the embedded "
                             "simulated motor (interface sim); use --live for a running daemon");
  }
  // The embedded daemon loads the calibration and models written to the
  // output directory: commands load files only from configured directories.
  servod::ServodConfig offline = config;
  std::filesystem::create_directories(options.out_dir);
  offline.commands.file_directories.push_back(std::filesystem::canonical(options.out_dir).string());
  InProcessRunner runner(offline);
  return run(options, runner, progress);
}

namespace {

/// The error budget (ErrorBudget): three runs of the oracle on runners that
/// keep no source, the disturbance alone and the encoder alone; none without
/// such runners (live) or without the oracle's evaluation.
template <typename Tell>
ErrorBudget error_budget(const Report& report, const ExperimentRunner& runner, const servod::ProgramFile& program,
                         const std::string& program_path, double period_s, const Tell& tell) {
  const auto oracle = std::find_if(report.results.begin(), report.results.end(),
                                   [](const auto& r) { return r.name == "oracle" && r.evaluated; });
  if (oracle == report.results.end() || runner.simulated_motor() == nullptr) return {};
  const auto oracle_tracking_m2 = [&](sim::ErrorSources kept, const char* what) {
    tell("error budget", 0.0, what);
    const std::unique_ptr<ExperimentRunner> on = runner.runner_with_sources(kept);
    if (!on) throw std::logic_error("error budget: a runner on a simulated motor offers no runner with other sources");
    on->enable();
    on->set_commutation(servo::CommutationMode::kOracle);
    on->load_feedforward(oracle->feedforward, "");
    return evaluate(on->run_program(program, program_path, std::string("oracle, ") + what, Disturbance::kRestarts),
                    period_s)
        .tracking_mse_m2;
  };
  ErrorBudget budget;
  budget.loop_m2 = oracle_tracking_m2({false, false}, "no error source");
  budget.disturbance_m2 = oracle_tracking_m2({true, false}, "the force disturbance alone") - budget.loop_m2;
  budget.encoder_m2 = oracle_tracking_m2({false, true}, "the encoder alone") - budget.loop_m2;
  budget.computed = true;
  tell("error budget", 1.0, "done");
  return budget;
}

}  // namespace

Report run(const Options& options, ExperimentRunner& runner, const std::function<void(const Progress&)>& progress) {
  const auto start = Clock::now();
  const auto tell = [&](const std::string& step, double fraction, const std::string& detail) {
    if (progress) progress({step, fraction, detail});
  };
  Report report;
  report.config_path = options.config_path;
  // The daemon opens the files it is sent itself: absolute paths.
  const std::string dir = std::filesystem::absolute(options.out_dir).lexically_normal().string();
  const auto written = [&](const std::string& name) { report.files.push_back(name); return dir + "/" + name; };

  const servod::ServodConfig config = servod::load_servod_config(options.config_path);
  const MotorDescription motor = config.motor;
  report.coil_sets = motor.coil_sets;
  report.encoder_reference = servod::encoder_reference(config);
  if (const std::string refusal = payload_refusal(options); !refusal.empty()) throw std::runtime_error(refusal);
  // Without a force sensor only the laws from positions are commissioned.
  check_force_sensor(config, options);
  const bool sensor = can::has_force_sensor(config.servo.protocol);
  // The reference must fit this motor's soft limits; a program made for a
  // longer stroke is scaled about the stroke centre (and the report says so).
  // A running daemon reads the program file itself, so live it must fit as it is.
  const auto fit = [&](const std::string& path, const char* what) {
    bool scaled = false;
    auto fitted = servod::fit_program(servod::load_program_file(path), config.servo.soft_limit_min_m,
                                      config.servo.soft_limit_max_m, scaled);
    if (scaled && options.live) {
      throw std::runtime_error(path + ": the " + std::string(what) + " leaves the soft limits of " +
                               options.config_path + "; live commissioning runs program files as they are");
    }
    if (scaled) report.notes.push_back(std::string(what) + " '" + path + "' scaled to the soft limits of this motor");
    return fitted;
  };
  const std::string config_dir = std::filesystem::absolute(options.config_path).parent_path().string();
  const ProgramPaths paths = program_paths(options);
  const std::string program_path = paths.evaluation;
  const servod::ProgramFile program = fit(program_path, "evaluation program");
  const control::MoveProgram timeline(program.start_m, program.steps);
  const std::string experiment_path = paths.experiment;
  const servod::ProgramFile experiment_program = fit(experiment_path, "experiment program");
  report.experiment_program = experiment_path;
  report.evaluation_program = program_path;
  std::optional<servod::ProgramFile> validation_program;
  std::string validation_path;
  if (options.validation_program_path != "none") {
    report.validation_program = options.validation_program_path.empty() ? config_dir + "/programs/validation.yaml"
                                                                        : options.validation_program_path;
    validation_path = paths.validation;
    validation_program = fit(report.validation_program, "validation program");
  }

  // The first command: live, it proves the daemon answers before anything is written.
  runner.enable();
  std::filesystem::create_directories(dir);
  // Until the report is written the directory says it is incomplete.
  IncompleteMarker incomplete(dir, "commissioning");

  // 1. Experiments of Algorithms 1 and 2.
  auto step_start = Clock::now();
  std::filesystem::create_directories(dir + "/logs");
  // Every run is also an LCM log (the daemon's own telemetry types), from
  // which `clm log2csv`, `clm calibrate` and `clm identify` re-run the steps.
  const auto open_log = [&](const std::string& name) {
    report.files.push_back("logs/" + name);
    runner.open_log(dir + "/logs/" + name);
  };
  const int runs = 2 * motor.coil_sets;
  // Every coil set at Δ = ∓π/4 in turn, in one log, not resumable (the
  // first pass and the payload's below; the main pass has a log per run).
  const auto run_experiments = [&](const std::string& log, const std::string& step, const std::string& name) {
    open_log(log);
    std::vector<Recording> recordings;
    for (int l = 1; l <= motor.coil_sets; ++l) {
      for (double delta : {-kPi / 4, kPi / 4}) {
        tell(step, static_cast<double>(recordings.size()) / runs,
             "coil set " + std::to_string(l) + ", delta " + (delta < 0 ? "-pi/4" : "+pi/4"));
        runner.set_experiment(l, delta);
        recordings.push_back(runner.run_program(experiment_program, experiment_path,
                                                name + " coil set " + std::to_string(l), Disturbance::kRunsOn));
      }
    }
    runner.close_log();
    return recordings;
  };
  // 1a. Where the motor file describes the drive's current loop, the cycle
  // compensates the back-EMF of every coil set, driven or not, with the
  // gains of the law in service (servo_cycle.cpp): before anything is
  // identified the drive's nominal law, whose constant and offset are a
  // tenth off on a real motor and the same for every coil set. The
  // compensation's error is then a force of velocity and acceleration that
  // no law of position fits. So a first pass of the experiments gives a
  // spline model (from forces, or from positions for an axis commissioned
  // without a force sensor), put in service, and the experiments calibrated
  // and identified on run with its gains (docs/commutation.md, "The
  // experiments' back-EMF"). Live it is not resumable: a resumed
  // commissioning runs it again.
  if (!motor.current_loop.ideal() && (sensor || options.no_force_sensor)) {
    const std::vector<Recording> nominal =
        run_experiments("experiments-nominal.lcm", "experiments on the drive's law", "nominal experiment");
    const std::string csv = written("experiments-nominal.csv");
    // Commissioned as an axis without a force sensor, no force is used here
    // either: the spline from positions at the scale given (--mass-kg, a
    // friction), else at control.mass_kg (a payload's mass comes later),
    // whose few per cent off are the gains' error.
    write_experiment_csv(csv, nominal, motor.drive_profile, !options.no_force_sensor);
    const data::ExperimentData data = read_experiments(csv, motor, report);
    ModelFile first;
    if (options.no_force_sensor) {
      data::PositionIdentifyOptions position = options.position;
      if (position.motion.scale() == identification::MotionFitOptions::Scale::kNominal) {
        position.motion.mass_kg = config.control_mass_kg;  // no scale given: the configured mass
      }
      first = data::identify_from_position(data, motor, position).model;
    } else {
      data::IdentifyOptions identify = options.identify;
      identify.kind = ModelKind::kSpline;
      identify.select_capacity = false;  // its gains are needed to a few per cent, not its best knot spacing
      std::vector<data::CoilSetIdentification> reports;
      first = data::identify_motor(data, motor, identify, reports, [&](const data::IdentifyProgress& p) {
        tell("experiments on the drive's law", 1.0, "identifying: " + p.what);
      });
    }
    first.provenance.data_sha256 = sha256_file(csv);
    first.provenance.generator = "clm commission";
    const std::string model = written("model-spline-nominal.yaml");
    write_file_atomically(model, format_model_file(first));
    runner.load_model(servo::CommutationMode::kSpline, model);
    runner.set_commutation(servo::CommutationMode::kSpline);
    tell("experiments on the drive's law", 1.0, "done; the spline identified from them in service");
    report.steps.push_back({"experiments on the drive's law", seconds_since(step_start)});
    step_start = Clock::now();
  }
  std::vector<Recording> experiments;
  // Live, each experiment has a log of its own and is listed in the progress
  // file once complete, so that --resume can reuse it (progress.hpp); the
  // logs are joined into experiments.lcm at the end.
  CommissionProgress done{options.identity, {}};
  if (options.resume) done = read_progress(dir);  // checked by the preflight
  const std::size_t reusable = done.experiments.size();
  if (options.live && !options.resume) write_progress(dir, done);
  std::vector<std::string> experiment_logs;
  if (!options.live) open_log("experiments.lcm");
  for (int l = 1; l <= motor.coil_sets; ++l) {
    for (double delta : {-kPi / 4, kPi / 4}) {
      const std::size_t k = experiments.size();
      const std::string what = "coil set " + std::to_string(l) + ", delta " + (delta < 0 ? "-pi/4" : "+pi/4");
      const std::string name = "experiment coil set " + std::to_string(l);
      tell("experiments", static_cast<double>(k) / runs, what);
      if (!options.live) {
        runner.set_experiment(l, delta);
        experiments.push_back(runner.run_program(experiment_program, experiment_path, name, Disturbance::kRunsOn));
        continue;
      }
      const std::string log = "logs/experiment-" + std::to_string(k + 1) + ".lcm";
      report.files.push_back(log);
      experiment_logs.push_back(dir + "/" + log);
      if (k < reusable) {
        const CompletedExperiment& completed = done.experiments[k];
        if (completed.coil_set != l || completed.delta_rad != delta || completed.log != log) {
          throw std::runtime_error("--resume: " + std::string(kProgressFile) + " lists experiment " +
                                   std::to_string(k + 1) + " as coil set " + std::to_string(completed.coil_set) +
                                   " in " + completed.log + ", expected " + what + " in " + log);
        }
        experiments.push_back(read_experiment_recording(dir + "/" + log, name));
        tell("experiments", static_cast<double>(k + 1) / runs, what + ": reused");
        continue;
      }
      runner.set_experiment(l, delta);
      runner.open_log(dir + "/" + log);
      experiments.push_back(runner.run_program(experiment_program, experiment_path, name, Disturbance::kRunsOn));
      runner.close_log();
      done.experiments.push_back({l, delta, log, sha256_file(dir + "/" + log)});
      write_progress(dir, done);
    }
  }
  if (options.live) {
    report.files.push_back("logs/experiments.lcm");
    concatenate_logs(experiment_logs, dir + "/logs/experiments.lcm");
    if (options.resume) {
      report.notes.push_back("resumed: " + std::to_string(std::min<std::size_t>(reusable, experiments.size())) +
                             " of " + std::to_string(runs) + " experiments reused from " + std::string(kProgressFile) +
                             "; the identification and every law's evaluation ran anew");
    }
  } else {
    runner.close_log();
  }
  tell("experiments", 1.0, "done");
  report.steps.push_back({"experiments", seconds_since(step_start)});

  // 1b. The same experiments with a known payload mounted, for the mass
  // without a force sensor (docs/commissioning.md, "The force scale from a
  // known payload"). Live they are not resumable: a resumed commissioning
  // runs them again.
  std::vector<Recording> payload_experiments;
  if (options.payload_kg > 0.0) {
    step_start = Clock::now();
    runner.set_payload(options.payload_kg);
    payload_experiments =
        run_experiments("experiments-payload.lcm", "experiments with the payload", "payload experiment");
    runner.set_payload(0.0);
    tell("experiments with the payload", 1.0, "done");
    report.steps.push_back({"experiments with the payload", seconds_since(step_start)});
  }

  // 2. Calibration and identification, through the same code as the offline tools.
  ModelFile models[2];
  bool paper_is_chosen = true;
  std::optional<data::ExperimentData> force_data;
  if (sensor) {
    force_data = identify_from_forces(options, motor, experiments, written, tell, report, models, paper_is_chosen);
  }
  // 2b. From the same experiments' positions: without a force sensor, or
  // beside the force models when their mechanics fit gives the mass.
  if (options.no_force_sensor || report.spline_selection.nuisance) {
    const bool beside_forces = sensor && !options.no_force_sensor;
    identify_from_positions(options, config, experiments, payload_experiments, written, tell,
                            beside_forces ? &models[1] : nullptr, beside_forces ? &*force_data : nullptr, report);
  }
  if (sensor) {
    // A law the daemon would refuse cannot go into service (checked as
    // clm-servod checks it, blended beyond its range to the calibration
    // loaded before it).
    const std::vector<ClassicalEstimate> outside = report.calibration_paper.estimates();
    const LawLimits limits = servod::law_limits(config);
    const auto check = [&](const char* law, const ElectromagneticModel& model) {
      const LawCheck verdict = check_blended_law(model, outside, limits);
      if (!verdict.accepted()) report.refused_laws[law] = describe(verdict);
    };
    check("pgnn", models[0].model);
    check("spline", models[1].model);
    if (report.from_position) check("spline-position", report.position.model.model);
    recommend(report);
  }
  if (options.no_force_sensor) {
    // Commissioned as an axis without a force sensor: the laws from positions
    // are the result, the force-sensor ones (when there is a sensor) a comparison.
    report.recommended = "spline-position";
    report.decided_by = "no force sensor";
    report.verdict = data::Verdict{};
    report.verdict.recommended = report.recommended;
    report.recommendation =
        sensor ? "commissioned from positions (--no-force-sensor); the force-sensor laws beside it are a comparison, "
                 "and alone they would give " + report.force_recommended
               : "the axis has no force sensor: the spline model from positions is the one model";
  }
  const sim::SimulatedMotor* simulated = runner.simulated_motor();
  if (simulated != nullptr && sensor) {
    write_truth_comparison(dir, *simulated, models[0], models[1], motor);
    report.files.push_back("truth-comparison.csv");
  }

  // 3. Load the results into the daemon.
  if (sensor) {
    runner.load_calibration(dir + "/calibration.yaml");
    runner.load_model(servo::CommutationMode::kSpline, dir + "/model-spline.yaml");
  }
  // The feedforward runs' zero feedforward, as a file a running daemon can load.
  servod::FeedforwardFile no_feedforward;
  no_feedforward.generator = "clm commission";
  const std::string no_feedforward_path = written("feedforward-none.yaml");
  write_file_atomically(no_feedforward_path, servod::format_feedforward_file(no_feedforward));

  // 4. Per commutation: feedforward identification, then evaluation. Each
  // law loads its own model or calibration first (the daemon has one slot
  // per law: the paper's PGNN and the chosen one share the PGNN slot), so
  // the model it runs does not depend on which laws ran before it.
  struct Commutation {
    const char* name;
    servo::CommutationMode mode;
    std::string model;        // loaded into the mode's slot first, when not empty
    std::string calibration;  // loaded into the classical law first, when not empty
  };
  std::vector<Commutation> commutations = {{"original", servo::CommutationMode::kOriginal, "", ""}};
  if (sensor) {
    commutations.insert(
        commutations.end(),
        {{"classical", servo::CommutationMode::kClassical, "", dir + "/calibration.yaml"},
         {"pgnn-paper", servo::CommutationMode::kPgnn, paper_is_chosen ? "" : dir + "/model-pgnn-paper.yaml", ""},
         {"pgnn", servo::CommutationMode::kPgnn, dir + "/model-pgnn.yaml", ""},
         {"spline", servo::CommutationMode::kSpline, dir + "/model-spline.yaml", ""}});
  }
  if (options.no_force_sensor) {
    commutations.push_back({"classical-position", servo::CommutationMode::kClassical, "",
                            dir + "/calibration-position.yaml"});
  }
  if (report.from_position) {
    commutations.push_back({"spline-position", servo::CommutationMode::kSpline,
                            dir + "/model-spline-position.yaml", ""});
  }
  commutations.push_back({"oracle", servo::CommutationMode::kOracle, "", ""});
  // Each law's runs depend only on the files loaded for it, so the laws are
  // evaluated side by side on two daemons when the runner offers a second
  // one (in process: a second daemon core with its own simulated motor, on
  // another thread), law k on daemon k mod 2; what each law's runs give, and
  // the files, steps and results, are merged in the order of `commutations`
  // whatever finishes first. Live there is one daemon and the laws run in turn.
  struct LawOutcome {
    std::vector<std::string> files;
    std::optional<CommutationResult> result, validation;
    std::optional<StepTime> step;
  };
  std::vector<LawOutcome> outcomes(commutations.size());
  std::unique_ptr<ExperimentRunner> side = runner.side_runner();
  if (side) side->enable();
  std::mutex progress_mutex;
  std::size_t finished = 0;
  const auto evaluate_law = [&](ExperimentRunner& on, std::size_t k) {
    const auto& [name, mode, model, calibration] = commutations[k];
    LawOutcome& outcome = outcomes[k];
    const auto law_file = [&](const std::string& file) {
      outcome.files.push_back(file);
      return dir + "/" + file;
    };
    const auto law_start = Clock::now();
    if (mode == servo::CommutationMode::kOracle && !on.oracle_unavailable_reason().empty()) {
      const std::string reason = on.oracle_unavailable_reason();
      outcome.result = CommutationResult{name, false, reason};
      if (validation_program) outcome.validation = CommutationResult{name, false, reason};
      return;
    }
    if (std::string(name) == "pgnn-paper" && paper_is_chosen) return;  // the same model as "pgnn": copied below
    try {
      if (!model.empty()) on.load_model(mode, model);
      if (!calibration.empty()) on.load_calibration(calibration);
    } catch (const LawRefused& refused) {
      // Not run, and said so: the daemon judged the law unfit to drive the
      // axis. The law recommended for service must run, or nothing is recommended.
      if (name == report.recommended) {
        throw std::runtime_error("the recommended law " + std::string(name) + " was refused: " + refused.what());
      }
      outcome.result = CommutationResult{name, false, refused.what()};
      if (validation_program) outcome.validation = CommutationResult{name, false, refused.what()};
      return;
    }
    on.set_commutation(mode);
    on.load_feedforward(no_feedforward.parameters, no_feedforward_path);
    const auto open_law_log = [&](const std::string& log) {
      outcome.files.push_back("logs/" + log);
      on.open_log(dir + "/logs/" + log);
    };
    open_law_log(std::string("feedforward-data-") + name + ".lcm");
    const Recording identification_run = on.run_program(program, program_path, std::string(name) + " feedforward data", Disturbance::kRestarts);
    on.close_log();
    write_feedforward_csv(law_file(std::string("feedforward-data-") + name + ".csv"), identification_run);
    servod::FeedforwardFile ff_file;
    ff_file.parameters = identify_ff(identification_run);
    ff_file.generator = "clm commission";
    const std::string ff_path = law_file(std::string("feedforward-") + name + ".yaml");
    write_file_atomically(ff_path, servod::format_feedforward_file(ff_file));
    on.load_feedforward(ff_file.parameters, ff_path);
    open_law_log(std::string("evaluation-") + name + ".lcm");
    const Recording evaluation = on.run_program(program, program_path, std::string(name) + " evaluation", Disturbance::kRestarts);
    on.close_log();
    write_evaluation_csv(law_file(std::string("evaluation-") + name + ".csv"), evaluation, timeline);
    CommutationResult result = evaluate(evaluation, config.servo.period_s);
    result.tracking_split = split_tracking(evaluation, config);
    result.name = name;
    result.feedforward = ff_file.parameters;
    outcome.result = result;
    if (validation_program) {
      // Held out: neither the models nor the feedforward saw this trajectory.
      open_law_log(std::string("validation-") + name + ".lcm");
      const Recording held_out =
          on.run_program(*validation_program, validation_path, std::string(name) + " validation",
                           Disturbance::kRestarts);
      on.close_log();
      const control::MoveProgram validation_timeline(validation_program->start_m, validation_program->steps);
      write_evaluation_csv(law_file(std::string("validation-") + name + ".csv"), held_out, validation_timeline);
      CommutationResult validation = evaluate(held_out, config.servo.period_s);
      validation.name = name;
      validation.feedforward = ff_file.parameters;
      outcome.validation = validation;
    }
    outcome.step = StepTime{std::string("evaluation ") + name, seconds_since(law_start)};
  };
  const auto evaluate_laws = [&](ExperimentRunner& on, std::size_t first, std::size_t stride) {
    for (std::size_t k = first; k < commutations.size(); k += stride) {
      {
        const std::lock_guard lock(progress_mutex);
        tell("evaluation", static_cast<double>(finished) / static_cast<double>(commutations.size()),
             commutations[k].name);
      }
      evaluate_law(on, k);
      const std::lock_guard lock(progress_mutex);
      ++finished;
    }
  };
  if (side) {
    std::exception_ptr side_failure;
    std::thread beside([&] {
      try {
        evaluate_laws(*side, 1, 2);
      } catch (...) {
        side_failure = std::current_exception();
      }
    });
    try {
      evaluate_laws(runner, 0, 2);
    } catch (...) {
      beside.join();
      throw;
    }
    beside.join();
    if (side_failure) std::rethrow_exception(side_failure);
  } else {
    evaluate_laws(runner, 0, 1);
  }
  for (auto& outcome : outcomes) {
    report.files.insert(report.files.end(), outcome.files.begin(), outcome.files.end());
    if (outcome.result) report.results.push_back(*outcome.result);
    if (outcome.validation) report.validation.push_back(*outcome.validation);
    if (outcome.step) report.steps.push_back(*outcome.step);
  }
  tell("evaluation", 1.0, "done");
  // With the paper's size chosen, "pgnn-paper" is that same model and run.
  const auto copy_chosen = [&](std::vector<CommutationResult>& results) {
    const auto chosen = std::find_if(results.begin(), results.end(), [](const auto& r) { return r.name == "pgnn"; });
    if (!paper_is_chosen || chosen == results.end()) return;
    CommutationResult paper = *chosen;
    paper.name = "pgnn-paper";
    results.insert(chosen, paper);
  };
  copy_chosen(report.results);
  copy_chosen(report.validation);
  report.budget = error_budget(report, runner, program, program_path, config.servo.period_s, tell);
  report.live = runner.live_summary();
  for (const auto& note : runner.notes()) report.notes.push_back(note);
  report.total_wall_s = seconds_since(start);
  write_file_atomically(written("report.json"), report_json(report));
  write_file_atomically(written("report.md"), report_markdown(report));
  incomplete.finished();
  return report;
}

}  // namespace clm::commission
