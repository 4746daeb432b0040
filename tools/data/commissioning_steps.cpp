#include "tools/data/commissioning_steps.hpp"

#include <cstdio>
#include <ctime>
#include <limits>
#include <mutex>
#include <numeric>
#include <stdexcept>

#include "commutation/calibration.hpp"
#include "commutation/identification/linear_parameters.hpp"
#include "commutation/identification/nuisance.hpp"
#include "tools/data/for_each_coil_set.hpp"

namespace clm::data {

CalibrationFile calibrate_motor(const ExperimentData& data, const MotorDescription& motor, CalibrationMethod method) {
  CalibrationFile file;
  file.pole_pitch_m = motor.pole_pitch_m;
  file.drive = motor.drive;
  file.method = method == CalibrationMethod::kAlgorithm1    ? "algorithm1"
                : method == CalibrationMethod::kOffsetRobust ? "offset_robust"
                                                             : "position";
  if ((method == CalibrationMethod::kPosition) == data.measured_forces) {
    throw std::runtime_error(data.origin + (data.measured_forces
                                                ? ": the data have force columns; calibration from positions is for "
                                                  "data without"
                                                : ": no force columns (Fy_N, Fx_N, Tz_Nm): calibrate from positions"));
  }
  for (const auto& experiment : data.coil_sets) {
    for (std::size_t g = 0; g < 2; ++g) {
      if (experiment.driving_force_N[g].size() != experiment.position_m[g].size()) {
        throw std::runtime_error(data.origin + ": coil set " + std::to_string(experiment.coil_set) +
                                 ": no driving force: the position model has not reconstructed it");
      }
    }
    const CalibrationGroup first{experiment.delta_rad[0], experiment.position_m[0], experiment.magnitude_N[0],
                                 experiment.driving_force_N[0]};
    const CalibrationGroup second{experiment.delta_rad[1], experiment.position_m[1], experiment.magnitude_N[1],
                                  experiment.driving_force_N[1]};
    CalibrationResult result;
    try {
      if (method != CalibrationMethod::kOffsetRobust) {
        result = calibrate_classical(motor.drive.motor_constant_N_per_A, motor.drive.phase_offset_rad, first, second);
      } else {
        identification::SplineOptions grid;
        const auto basis = identification::spline_basis_for(experiment.dataset.position_m, motor.pole_pitch_m, grid);
        result = calibrate_classical_offset_robust(motor.drive.motor_constant_N_per_A, motor.drive.phase_offset_rad,
                                                   first, second, basis);
      }
    } catch (const CalibrationError& e) {
      throw std::runtime_error(data.origin + ": coil set " + std::to_string(experiment.coil_set) + ": " + e.what());
    }
    CalibrationFile::CoilSet entry;
    entry.estimate = {result.motor_constant_N_per_A, result.phase_offset_rad};
    entry.delta_rad = experiment.delta_rad;
    entry.gain_ratio = {result.gain_ratio[0], result.gain_ratio[1]};
    entry.residual_rms_N = {result.residual_rms_N[0], result.residual_rms_N[1]};
    entry.quality = result.quality;
    file.coil_sets.push_back(entry);
  }
  file.created_utc = utc_timestamp();
  return file;
}

namespace {

/// The fit quality of the model put to use, into its model file's costs.
void record_fit_quality(const identification::IdentificationReport& report, CoilSetCosts& costs) {
  costs.regressor_condition = report.regressors.condition;
  costs.unexcited_parameters = report.regressors.unexcited;
}

// One coil set's data, split into training and held-out blocks.
struct SplitData {
  int coil_set = 0;  // 1-based
  identification::CoilSetDataset training, validation;
};

// Σ over coil sets of the model's held-out F_y MSE over the physics-only
// fit's (on the training data when nothing is held out). The driving
// direction alone: it is what tracking depends on, and in x and z both fits
// sit near the sensor's noise, whose ratios would drown the differences.
double selection_score(const std::vector<CoilSetIdentification>& reports) {
  double score = 0.0;
  for (const auto& entry : reports) {
    const auto& r = entry.report;
    const bool held_out = entry.validation_samples > 0;
    const double model = held_out ? r.model_validation[0] : r.model_training[0];
    const double physics = held_out ? r.physics_validation[0] : r.physics_training[0];
    if (physics > 0.0) score += model / physics;
  }
  return score;
}

// v_c at which the identifiability of the direction-dependent force is
// judged: the middle of the grid.
constexpr double kNominalSmoothing_m_per_s = 2e-3;

// A length in mm with three significant digits, for trial names.
std::string millimetres(double length_m) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g", length_m * 1e3);
  return text;
}

}  // namespace

ModelFile identify_motor(const ExperimentData& data, const MotorDescription& motor, const IdentifyOptions& options,
                         std::vector<CoilSetIdentification>& reports,
                         const std::function<void(const IdentifyProgress&)>& progress, IdentifySummary* summary_out) {
  if (!data.measured_forces) {
    throw std::runtime_error(data.origin + ": no force columns (Fy_N, Fx_N, Tz_Nm): the model is identified from "
                             "positions (spline class only)");
  }
  IdentifySummary summary;
  // One normalisation and one knot grid for the whole model, from all positions.
  Eigen::Index total = 0;
  for (const auto& experiment : data.coil_sets) total += experiment.dataset.size();
  Eigen::VectorXd all_positions(total);
  Eigen::Index at = 0;
  for (const auto& experiment : data.coil_sets) {
    all_positions.segment(at, experiment.dataset.size()) = experiment.dataset.position_m;
    at += experiment.dataset.size();
  }
  const PositionNormalisation normalisation = identification::normalisation_for(all_positions);

  // Nuisance terms: the sensor's F_y offset from the mechanics, removed from
  // the data; the velocities that carry the direction-dependent force.
  if (options.nuisance) {
    std::vector<identification::MotionRecord> records;
    for (const auto& experiment : data.coil_sets) records.push_back(experiment.motion);
    try {
      summary.sensor_offset = identification::fit_driving_sensor_offset(records);
      summary.nuisance = true;
    } catch (const std::invalid_argument& e) {
      summary.nuisance_skipped = e.what();
    }
  }
  std::vector<SplitData> splits;
  for (const auto& experiment : data.coil_sets) {
    identification::CoilSetDataset dataset = experiment.dataset;
    if (summary.nuisance) {
      dataset.wrench.row(0).array() -= summary.sensor_offset.offset_N;
    } else {
      dataset.velocity_m_per_s.resize(0);
    }
    const auto split = identification::split_contiguous_blocks(dataset, options.validation_fraction);
    splits.push_back({experiment.coil_set, dataset.subset(split.training), dataset.subset(split.validation)});
  }

  // The direction-dependent force only where the experiments tell it from a
  // gain (docs/commutation.md, "Nuisance terms"); else the models are fit
  // without it and the report says why.
  if (summary.nuisance) {
    for (const auto& part : splits) {
      summary.direction_force_inflation = std::max(
          summary.direction_force_inflation,
          identification::direction_force_inflation(part.training, motor.pole_pitch_m, kNominalSmoothing_m_per_s));
    }
    summary.direction_force = summary.direction_force_inflation <= identification::kMaxDirectionForceInflation;
    if (!summary.direction_force) {
      char reason[240];
      std::snprintf(reason, sizeof(reason),
                    "the direction-dependent force is not identified: the experiments do not tell it from a gain "
                    "(variance inflation %.3g > %.3g; run moves at several speeds and accelerations, "
                    "programs/identification.yaml)",
                    summary.direction_force_inflation, identification::kMaxDirectionForceInflation);
      summary.direction_force_skipped = reason;
      for (auto& part : splits) {
        part.training.velocity_m_per_s.resize(0);
        part.validation.velocity_m_per_s.resize(0);
      }
    }
  }

  // Every trial fits all coil sets with the given class options.
  const int count = static_cast<int>(data.coil_sets.size());
  const bool select = options.select_capacity && options.validation_fraction > 0.0;
  const int smoothing_trials =
      summary.direction_force ? static_cast<int>(std::size(identification::kDirectionSmoothingGrid_m_per_s)) : 0;
  const int capacity_trials = !select ? 1
                              : options.kind == ModelKind::kPgnn ? static_cast<int>(kPgnnCapacityGrid.size())
                                                                 : static_cast<int>(kSplineKnotsPerPolePitch.size());
  const int trials = smoothing_trials + capacity_trials;
  int trial = 0;
  const auto fit_all = [&](ModelKind kind, const identification::PgnnOptions& pgnn,
                           const identification::SplineOptions& spline, const std::string& what) {
    ++trial;
    CapacityTrial result;
    result.capacity = what;
    ModelFile& file = result.model;
    auto& model = file.model;
    model.kind = kind;
    model.pole_pitch_m = motor.pole_pitch_m;
    model.normalisation = normalisation;
    if (kind == ModelKind::kPgnn) model.harmonics = pgnn.harmonics;
    model.spline_basis = identification::spline_basis_for(all_positions, motor.pole_pitch_m, spline);
    auto& nuisance = file.provenance.nuisance;
    nuisance.identified = summary.nuisance;
    nuisance.sensor_offset_y_N = summary.sensor_offset.offset_N;
    nuisance.direction_smoothing_m_per_s = kind == ModelKind::kPgnn ? pgnn.direction_smoothing_m_per_s
                                                                    : spline.direction_smoothing_m_per_s;
    // The coil sets are independent problems (each its own data, seed and
    // solver), identified side by side; the results do not depend on the
    // order in which they finish.
    std::vector<CoilSetIdentification> entries(splits.size());
    std::vector<CoilSetModel> parts(splits.size());
    std::vector<double> done(splits.size(), 0.0);
    std::mutex progress_mutex;
    const auto report = [&](std::size_t l, double fraction) {
      if (!progress) return;
      const std::lock_guard lock(progress_mutex);
      done[l] = fraction;
      progress({count, std::accumulate(done.begin(), done.end(), 0.0), trial, trials, what});
    };
    for_each_coil_set(splits.size(), [&](std::size_t l) {
      const auto& part = splits[l];
      CoilSetIdentification& entry = entries[l];
      entry.training_samples = static_cast<std::size_t>(part.training.size());
      entry.validation_samples = static_cast<std::size_t>(part.validation.size());
      if (kind == ModelKind::kPgnn) {
        identification::PgnnOptions seeded = pgnn;
        seeded.seed = pgnn.seed + static_cast<std::uint64_t>(part.coil_set) * 1000;
        // Trials are scored on the training fit; the one kept is refit on all data below.
        seeded.refit_on_all_data = !select;
        const auto on_step = [&](const identification::PgnnProgress& p) {
          report(l, static_cast<double>(p.restart + 1) / (p.restarts + 1));
        };
        parts[l] = identification::identify_pgnn_coil_set(part.training, part.validation, motor.pole_pitch_m,
                                                          normalisation, seeded, entry.report, on_step);
      } else {
        parts[l] = identification::identify_spline_coil_set(part.training, part.validation, motor.pole_pitch_m,
                                                            model.spline_basis, spline, entry.report);
        report(l, 1.0);
      }
    });
    for (std::size_t l = 0; l < splits.size(); ++l) {
      const CoilSetIdentification& entry = entries[l];
      model.coil_sets.push_back(std::move(parts[l]));
      CoilSetCosts costs;
      for (std::size_t q = 0; q < 3; ++q) {
        const auto i = static_cast<Eigen::Index>(q);
        costs.physics_training[q] = entry.report.physics_training[i];
        costs.model_training[q] = entry.report.model_training[i];
        costs.physics_validation[q] = entry.report.physics_validation[i];
        costs.model_validation[q] = entry.report.model_validation[i];
      }
      record_fit_quality(entry.report, costs);
      file.provenance.costs.push_back(costs);
      const auto& c = entry.report.direction_force.amplitude;
      nuisance.direction_force_N_N_Nm.push_back({c[0], c[1], c[2]});
      result.coil_sets.push_back(entry);
    }
    model.validate();
    file.provenance.created_utc = utc_timestamp();
    result.validation_score = selection_score(result.coil_sets);
    return result;
  };

  // v_c of the direction-dependent force: a property of the motor, chosen
  // once with the spline class at the given spacing (linear, so cheap).
  identification::PgnnOptions pgnn = options.pgnn;
  identification::SplineOptions spline = options.spline;
  if (summary.direction_force) {
    double best = std::numeric_limits<double>::infinity();
    for (const double smoothing : identification::kDirectionSmoothingGrid_m_per_s) {
      identification::SplineOptions trial_spline = options.spline;
      trial_spline.direction_smoothing_m_per_s = smoothing;
      const double score = fit_all(ModelKind::kSpline, pgnn, trial_spline, "v_c " + shortest_double(smoothing) + " m/s")
                               .validation_score;
      summary.direction_smoothing_scores.emplace_back(smoothing, score);
      if (score < best) {
        best = score;
        pgnn.direction_smoothing_m_per_s = spline.direction_smoothing_m_per_s = smoothing;
      }
    }
  }

  // Capacity: the grid, or the options as given.
  if (options.kind == ModelKind::kPgnn) {
    const auto sizes =
        select ? std::vector<PgnnCapacity>(kPgnnCapacityGrid.begin(), kPgnnCapacityGrid.end())
               : std::vector<PgnnCapacity>{{options.pgnn.column_hidden, options.pgnn.cogging_hidden,
                                            options.pgnn.regularisation, !options.pgnn.harmonics.empty()}};
    for (const auto& [column, cogging, regularisation, harmonics] : sizes) {
      pgnn.column_hidden = column;
      pgnn.cogging_hidden = cogging;
      pgnn.regularisation = regularisation;
      pgnn.harmonics = !harmonics ? HarmonicOrders{} : select ? identification::field_harmonic_orders()
                                                                : options.pgnn.harmonics;
      summary.trials.push_back(fit_all(ModelKind::kPgnn, pgnn, spline,
                                       "pgnn " + std::to_string(column) + "/" + std::to_string(cogging) +
                                           " Lambda " + shortest_double(regularisation) +
                                           (harmonics ? " harmonics" : "")));
      summary.trials.back().column_hidden = column;
      summary.trials.back().cogging_hidden = cogging;
      summary.trials.back().regularisation = regularisation;
      summary.trials.back().harmonics = harmonics;
    }
  } else {
    std::vector<double> spacings;
    if (select) {
      for (const int per_pitch : kSplineKnotsPerPolePitch) spacings.push_back(motor.pole_pitch_m / per_pitch);
    } else {
      spacings.push_back(options.spline.knot_spacing_m > 0.0 ? options.spline.knot_spacing_m : motor.pole_pitch_m / 8.0);
    }
    for (const double spacing : spacings) {
      spline.knot_spacing_m = spacing;
      summary.trials.push_back(fit_all(ModelKind::kSpline, pgnn, spline,
                                       "spline knots " + millimetres(spacing) + " mm"));
      summary.trials.back().knot_spacing_m = spacing;
    }
  }
  for (std::size_t k = 1; k < summary.trials.size(); ++k) {
    if (summary.trials[k].validation_score < summary.trials[summary.chosen].validation_score) summary.chosen = k;
  }
  // The PGNN kept, and the paper's 2/16 (always reported), are polished on
  // every sample, as a model put to use is (docs/commutation.md, "Identification").
  if (options.kind == ModelKind::kPgnn && select) {
    for (std::size_t k = 0; k < summary.trials.size(); ++k) {
      CapacityTrial& kept = summary.trials[k];
      if (k != summary.chosen && !kept.is_paper_pgnn()) continue;
      pgnn.regularisation = kept.regularisation;
      pgnn.harmonics = kept.model.model.harmonics;
      for_each_coil_set(splits.size(), [&](std::size_t l) {
        auto& entry = kept.coil_sets[l];
        auto& coil_set = kept.model.model.coil_sets[l];
        coil_set = identification::refit_pgnn_coil_set(coil_set, entry.report.direction_force, splits[l].training,
                                                       splits[l].validation, motor.pole_pitch_m, normalisation, pgnn,
                                                       entry.report);
      });
      for (std::size_t l = 0; l < splits.size(); ++l) {
        const auto& entry = kept.coil_sets[l];
        const auto& c = entry.report.direction_force.amplitude;
        kept.model.provenance.nuisance.direction_force_N_N_Nm[l] = {c[0], c[1], c[2]};
        record_fit_quality(entry.report, kept.model.provenance.costs[l]);
      }
      kept.model.model.validate();
    }
  }
  const CapacityTrial& chosen = summary.trials[summary.chosen];
  reports = chosen.coil_sets;
  ModelFile file = chosen.model;
  if (summary_out != nullptr) *summary_out = std::move(summary);
  return file;
}

std::string utc_timestamp() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char buffer[32];
  std::strftime(buffer, sizeof(buffer), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return buffer;
}

}  // namespace clm::data
