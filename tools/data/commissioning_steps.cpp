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
  file.reference = data.reference;
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
  std::vector<std::size_t> validation_blocks;  // samples per held-out block, in the validation data's order
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
    splits.push_back({experiment.coil_set, dataset.subset(split.training), dataset.subset(split.validation),
                      split.validation_blocks});
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
  int trials_before = 0;  // trials of the batches already fitted
  // What one trial fits: the class and its options.
  struct TrialSpec {
    ModelKind kind;
    identification::PgnnOptions pgnn;
    identification::SplineOptions spline;
    std::string what;
  };
  // Fits every trial of `specs` on every coil set. The (trial, coil set)
  // pairs are independent problems (each its own data, seed and solver) and
  // run side by side on the machine's cores, each worker taking the next
  // pair; every result goes to its own slot, so nothing depends on which
  // worker ran it or when it finished. The trials come back in `specs`' order.
  const auto fit_trials = [&](const std::vector<TrialSpec>& specs) {
    std::vector<CapacityTrial> results(specs.size());
    std::vector<std::vector<CoilSetIdentification>> entries(specs.size(),
                                                            std::vector<CoilSetIdentification>(splits.size()));
    std::vector<std::vector<CoilSetModel>> parts(specs.size(), std::vector<CoilSetModel>(splits.size()));
    std::vector<double> done(specs.size() * splits.size(), 0.0);
    std::vector<UniformCubicBasis> bases;  // the knot grid of each trial (every model file carries one)
    for (const TrialSpec& spec : specs) {
      bases.push_back(identification::spline_basis_for(all_positions, motor.pole_pitch_m, spec.spline));
    }
    std::mutex progress_mutex;
    const auto report = [&](std::size_t task, double fraction) {
      if (!progress) return;
      const std::lock_guard lock(progress_mutex);
      done[task] = fraction;
      const double trials_done = std::accumulate(done.begin(), done.end(), 0.0) / static_cast<double>(splits.size());
      const int whole = std::min(static_cast<int>(trials_done), static_cast<int>(specs.size()) - 1);
      progress({count, (trials_done - whole) * count, trials_before + whole + 1, trials,
                specs[task / splits.size()].what});
    };
    // The grids grow in cost towards their end: the last trial is started
    // first, so that no core waits on it at the end.
    for_each_task(specs.size() * splits.size(), [&](std::size_t order) {
      const std::size_t task = specs.size() * splits.size() - 1 - order;
      const std::size_t k = task / splits.size();
      const std::size_t l = task % splits.size();
      const TrialSpec& spec = specs[k];
      const auto& part = splits[l];
      CoilSetIdentification& entry = entries[k][l];
      entry.training_samples = static_cast<std::size_t>(part.training.size());
      entry.validation_samples = static_cast<std::size_t>(part.validation.size());
      if (spec.kind == ModelKind::kPgnn) {
        identification::PgnnOptions seeded = spec.pgnn;
        seeded.seed = spec.pgnn.seed + static_cast<std::uint64_t>(part.coil_set) * 1000;
        // Trials are scored on the training fit; the one kept is refit on all data below.
        seeded.refit_on_all_data = !select;
        const auto on_step = [&](const identification::PgnnProgress& p) {
          report(task, static_cast<double>(p.restart + 1) / (p.restarts + 1));
        };
        parts[k][l] = identification::identify_pgnn_coil_set(part.training, part.validation, motor.pole_pitch_m,
                                                             normalisation, seeded, entry.report, on_step);
      } else {
        parts[k][l] = identification::identify_spline_coil_set(part.training, part.validation, motor.pole_pitch_m,
                                                               bases[k], spec.spline, entry.report);
        report(task, 1.0);
      }
    });
    for (std::size_t k = 0; k < specs.size(); ++k) {
      const TrialSpec& spec = specs[k];
      CapacityTrial& result = results[k];
      result.capacity = spec.what;
      ModelFile& file = result.model;
      auto& model = file.model;
      model.kind = spec.kind;
      model.pole_pitch_m = motor.pole_pitch_m;
      model.normalisation = normalisation;
      if (spec.kind == ModelKind::kPgnn) model.harmonics = spec.pgnn.harmonics;
      model.spline_basis = bases[k];
      auto& nuisance = file.provenance.nuisance;
      nuisance.identified = summary.nuisance;
      nuisance.sensor_offset_y_N = summary.sensor_offset.offset_N;
      nuisance.direction_smoothing_m_per_s = spec.kind == ModelKind::kPgnn ? spec.pgnn.direction_smoothing_m_per_s
                                                                          : spec.spline.direction_smoothing_m_per_s;
      for (std::size_t l = 0; l < splits.size(); ++l) {
        const CoilSetIdentification& entry = entries[k][l];
        model.coil_sets.push_back(std::move(parts[k][l]));
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
      if (std::all_of(splits.begin(), splits.end(), [](const SplitData& p) { return p.validation.size() > 0; })) {
        for (std::size_t l = 0; l < splits.size(); ++l) {
          const auto& r = result.coil_sets[l].report;
          result.held_out.push_back(
              held_out_blocks(r.model_validation_y_N2, r.physics_validation_y_N2, splits[l].validation_blocks));
        }
      }
    }
    trials_before += static_cast<int>(specs.size());
    return results;
  };

  // v_c of the direction-dependent force: a property of the motor, chosen
  // once with the spline class at the given spacing (linear, so cheap).
  identification::PgnnOptions pgnn = options.pgnn;
  identification::SplineOptions spline = options.spline;
  if (summary.direction_force) {
    std::vector<TrialSpec> specs;
    for (const double smoothing : identification::kDirectionSmoothingGrid_m_per_s) {
      identification::SplineOptions trial_spline = options.spline;
      trial_spline.direction_smoothing_m_per_s = smoothing;
      specs.push_back({ModelKind::kSpline, pgnn, trial_spline, "v_c " + shortest_double(smoothing) + " m/s"});
    }
    const std::vector<CapacityTrial> fitted = fit_trials(specs);
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < specs.size(); ++k) {
      const double smoothing = specs[k].spline.direction_smoothing_m_per_s;
      const double score = fitted[k].validation_score;
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
    std::vector<TrialSpec> specs;
    for (const auto& [column, cogging, regularisation, harmonics] : sizes) {
      identification::PgnnOptions sized = pgnn;
      sized.column_hidden = column;
      sized.cogging_hidden = cogging;
      sized.regularisation = regularisation;
      sized.harmonics = !harmonics ? HarmonicOrders{} : select ? identification::field_harmonic_orders()
                                                                 : options.pgnn.harmonics;
      specs.push_back({ModelKind::kPgnn, sized, spline,
                       "pgnn " + std::to_string(column) + "/" + std::to_string(cogging) + " Lambda " +
                           shortest_double(regularisation) + (harmonics ? " harmonics" : "")});
    }
    summary.trials = fit_trials(specs);
    for (std::size_t k = 0; k < sizes.size(); ++k) {
      summary.trials[k].column_hidden = sizes[k].column_hidden;
      summary.trials[k].cogging_hidden = sizes[k].cogging_hidden;
      summary.trials[k].regularisation = sizes[k].regularisation;
      summary.trials[k].harmonics = sizes[k].harmonics;
    }
  } else {
    std::vector<double> spacings;
    if (select) {
      for (const int per_pitch : kSplineKnotsPerPolePitch) spacings.push_back(motor.pole_pitch_m / per_pitch);
    } else {
      spacings.push_back(options.spline.knot_spacing_m > 0.0 ? options.spline.knot_spacing_m : motor.pole_pitch_m / 8.0);
    }
    std::vector<TrialSpec> specs;
    for (const double spacing : spacings) {
      identification::SplineOptions spaced = spline;
      spaced.knot_spacing_m = spacing;
      specs.push_back({ModelKind::kSpline, pgnn, spaced, "spline knots " + millimetres(spacing) + " mm"});
    }
    summary.trials = fit_trials(specs);
    for (std::size_t k = 0; k < spacings.size(); ++k) summary.trials[k].knot_spacing_m = spacings[k];
  }
  for (std::size_t k = 1; k < summary.trials.size(); ++k) {
    if (summary.trials[k].validation_score < summary.trials[summary.chosen].validation_score) summary.chosen = k;
  }
  // The PGNN kept, and the paper's 2/16 (always reported), are polished on
  // every sample, as a model put to use is (docs/commutation.md, "Identification").
  if (options.kind == ModelKind::kPgnn && select) {
    std::vector<std::size_t> kept;
    for (std::size_t k = 0; k < summary.trials.size(); ++k) {
      if (k == summary.chosen || summary.trials[k].is_paper_pgnn()) kept.push_back(k);
    }
    // Every (kept trial, coil set) is its own problem: side by side.
    for_each_task(kept.size() * splits.size(), [&](std::size_t task) {
      CapacityTrial& trial = summary.trials[kept[task / splits.size()]];
      const std::size_t l = task % splits.size();
      identification::PgnnOptions polish = pgnn;
      polish.regularisation = trial.regularisation;
      polish.harmonics = trial.model.model.harmonics;
      auto& entry = trial.coil_sets[l];
      auto& coil_set = trial.model.model.coil_sets[l];
      coil_set = identification::refit_pgnn_coil_set(coil_set, entry.report.direction_force, splits[l].training,
                                                     splits[l].validation, motor.pole_pitch_m, normalisation, polish,
                                                     entry.report);
    });
    for (const std::size_t k : kept) {
      CapacityTrial& trial = summary.trials[k];
      for (std::size_t l = 0; l < splits.size(); ++l) {
        const auto& entry = trial.coil_sets[l];
        const auto& c = entry.report.direction_force.amplitude;
        trial.model.provenance.nuisance.direction_force_N_N_Nm[l] = {c[0], c[1], c[2]};
        record_fit_quality(entry.report, trial.model.provenance.costs[l]);
      }
      trial.model.model.validate();
    }
  }
  for (CapacityTrial& trial : summary.trials) trial.model.reference = data.reference;
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
