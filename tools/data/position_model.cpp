#include "tools/data/position_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "commutation/elementary.hpp"
#include "commutation/identification/dataset.hpp"
#include "commutation/identification/linear_parameters.hpp"
#include "commutation/identification/spline_fit.hpp"
#include "tools/data/commissioning_steps.hpp"
#include "tools/data/for_each_coil_set.hpp"

namespace clm::data {
namespace {

// Runs `runs` cut into contiguous blocks (ten per run) of which
// round(fraction·10), spread evenly, are held out.
struct SplitRuns {
  std::vector<identification::MotionRun> training, validation;
};

identification::MotionRun slice(const identification::MotionRun& run, Eigen::Index first, Eigen::Index count) {
  identification::MotionRun part{run.time_s.segment(first, count), run.position_m.segment(first, count),
                                  run.currents_A.middleCols(first, count), {}};
  if (run.currents_next_A.size() != 0) part.currents_next_A = run.currents_next_A.middleCols(first, count);
  return part;
}

SplitRuns split_runs(const std::vector<identification::MotionRun>& runs, double fraction) {
  constexpr int kBlocks = 10;
  const int held = static_cast<int>(std::lround(fraction * kBlocks));
  SplitRuns split;
  for (const auto& run : runs) {
    const Eigen::Index n = run.position_m.size();
    if (held == 0 || n < 3 * kBlocks) {
      split.training.push_back(run);
      continue;
    }
    for (int b = 0; b < kBlocks; ++b) {
      const Eigen::Index first = n * b / kBlocks, end = n * (b + 1) / kBlocks;
      const bool held_out = (b + 1) * held / kBlocks > b * held / kBlocks;
      (held_out ? split.validation : split.training).push_back(slice(run, first, end - first));
    }
  }
  return split;
}

// The fit's options with what the motor description says of the drive: its
// nominal commutation (the scale without a mass), its current loop and the
// delays from setpoint to force and of the position (the pairing).
identification::MotionFitOptions with_drive(identification::MotionFitOptions options, const MotorDescription& motor) {
  options.drive = motor.drive;
  options.current_loop = motor.current_loop;
  options.delay_s = motor.setpoint_delay_s + motor.position_delay_s;
  return options;
}

// Every position of every run of `data`, appended to `positions`.
void append_positions(const ExperimentData& data, std::vector<double>& positions) {
  for (const auto& experiment : data.coil_sets) {
    for (const auto& run : experiment.runs) positions.insert(positions.end(), run.position_m.begin(), run.position_m.end());
  }
}

Eigen::Map<const Eigen::VectorXd> as_vector(const std::vector<double>& values) {
  return {values.data(), static_cast<Eigen::Index>(values.size())};
}

// Every coil set on `basis`, at one mass: the given one, or the common one.
std::vector<identification::MotionFit> fit_all(const std::vector<std::vector<identification::MotionRun>>& runs,
                                               const ExperimentData& data, const MotorDescription& motor,
                                               const UniformCubicBasis& basis,
                                               const identification::MotionFitOptions& options) {
  std::vector<identification::MotionFit> fits(runs.size());
  for_each_coil_set(runs.size(), [&](std::size_t l) {
    try {
      fits[l] = identification::fit_driving_direction_from_motion(runs[l], motor.pole_pitch_m, basis, options);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(data.origin + ": coil set " + std::to_string(l + 1) + ": " + e.what());
    }
  });
  if (options.mass_kg <= 0.0) {
    const double mass_kg = identification::common_mass_kg(fits, options);
    if (!(mass_kg > 0.0) || !std::isfinite(mass_kg)) {
      throw std::runtime_error(data.origin + ": the gains or friction identified from positions point against the "
                               "reference that sets the scale; no mass fits them (give --mass-kg)");
    }
    for (auto& fit : fits) fit = fit.scaled_to_mass(mass_kg);
  }
  return fits;
}


// The spline model of `fits` on `basis`: F_y rows from positions, F_x and
// T_z rows zero.
ElectromagneticModel spline_model(const std::vector<identification::MotionFit>& fits, const UniformCubicBasis& basis,
                                  const MotorDescription& motor, const PositionNormalisation& normalisation) {
  ElectromagneticModel model;
  model.kind = ModelKind::kSpline;
  model.pole_pitch_m = motor.pole_pitch_m;
  model.normalisation = normalisation;
  model.spline_basis = basis;
  for (const auto& motion : fits) {
    CoilSetModel coil_set;
    coil_set.a_N_per_A.row(0) = motion.a_y;
    coil_set.b_N_per_A.row(0) = motion.b_y;
    coil_set.column_a_spline = SplineCoefficients::Zero(3, basis.size());
    coil_set.column_b_spline = SplineCoefficients::Zero(3, basis.size());
    coil_set.cogging_spline = SplineCoefficients::Zero(3, basis.size());
    coil_set.column_a_spline.row(0) = motion.column_a;
    coil_set.column_b_spline.row(0) = motion.column_b;
    coil_set.cogging_spline.row(0) = motion.cogging;
    model.coil_sets.push_back(std::move(coil_set));
  }
  model.validate();
  return model;
}

// `run` cut where its times come within `tolerance_s` of `excluded_s`
// (sorted): the stretches in between, as runs of their own.
void cut_at(const identification::MotionRun& run, const std::vector<double>& excluded_s, double tolerance_s,
            std::vector<identification::MotionRun>& into) {
  const Eigen::Index n = run.time_s.size();
  const auto excluded = [&](double t) {
    const auto it = std::lower_bound(excluded_s.begin(), excluded_s.end(), t - tolerance_s);
    return it != excluded_s.end() && *it <= t + tolerance_s;
  };
  for (Eigen::Index first = 0; first < n;) {
    if (excluded(run.time_s[first])) {
      ++first;
      continue;
    }
    Eigen::Index end = first + 1;
    while (end < n && !excluded(run.time_s[end])) ++end;
    into.push_back(slice(run, first, end - first));
    first = end;
  }
}
}  // namespace

PositionIdentification identify_from_position(const ExperimentData& data, const MotorDescription& motor,
                                              const PositionIdentifyOptions& options) {
  const identification::MotionFitOptions fit = with_drive(options.motion, motor);
  fit.validate("position identification");
  if (!(options.knot_spacing_m >= 0.0) || !(options.validation_fraction >= 0.0) ||
      !(options.validation_fraction < 1.0)) {
    throw std::invalid_argument("position identification: a negative knot spacing, or a held-out share outside [0, 1)");
  }
  std::vector<double> all_positions;
  append_positions(data, all_positions);
  std::vector<std::vector<identification::MotionRun>> training, validation, all;
  for (const auto& experiment : data.coil_sets) {
    SplitRuns split = split_runs(experiment.runs, options.validation_fraction);
    training.push_back(std::move(split.training));
    validation.push_back(std::move(split.validation));
    all.push_back(experiment.runs);
  }
  const auto basis_for = [&](double spacing) {
    identification::SplineOptions grid;
    grid.knot_spacing_m = spacing;
    return identification::spline_basis_for(as_vector(all_positions), motor.pole_pitch_m, grid);
  };

  PositionIdentification result;
  result.mass_given = fit.scale() == identification::MotionFitOptions::Scale::kMass;
  result.friction_given = fit.scale() == identification::MotionFitOptions::Scale::kFriction;
  result.knot_spacing_m = options.basis ? options.basis->spacing_m() : options.knot_spacing_m;
  // Nothing held out, nothing to choose by: the force-sensor spline's default.
  if (result.knot_spacing_m == 0.0 && options.validation_fraction == 0.0) {
    result.knot_spacing_m = motor.pole_pitch_m / 8.0;
  }
  if (result.knot_spacing_m == 0.0) {
    // The spacing whose fit on the training blocks balances the held-out ones best.
    double best = std::numeric_limits<double>::infinity();
    for (const int per_pitch : kSplineKnotsPerPolePitch) {
      const double spacing = motor.pole_pitch_m / per_pitch;
      const UniformCubicBasis basis = basis_for(spacing);
      const auto fits = fit_all(training, data, motor, basis, fit);
      double square_sum = 0.0;
      for (std::size_t l = 0; l < fits.size(); ++l) {
        const double rms =
            identification::motion_residual_rms_N(fits[l], validation[l], motor.pole_pitch_m, basis, fit);
        square_sum += std::isfinite(rms) ? rms * rms : 0.0;
      }
      const double score = std::sqrt(square_sum / static_cast<double>(fits.size()));
      result.spacing_scores.emplace_back(spacing, score);
      if (score < best) {
        best = score;
        result.knot_spacing_m = spacing;
      }
    }
  }
  const UniformCubicBasis basis = options.basis ? *options.basis : basis_for(result.knot_spacing_m);
  // The model kept: fit on the training blocks for its held-out figure, then on everything.
  const auto held_out_fits = fit_all(training, data, motor, basis, fit);
  for (std::size_t l = 0; l < held_out_fits.size(); ++l) {
    result.validation_residual_rms_N.push_back(
        identification::motion_residual_rms_N(held_out_fits[l], validation[l], motor.pole_pitch_m, basis, fit));
  }
  result.fits = fit_all(all, data, motor, basis, fit);
  result.mass_kg = result.fits.front().mass_kg;

  result.model.model =
      spline_model(result.fits, basis, motor, identification::normalisation_for(as_vector(all_positions)));
  result.model.provenance.rows_from = {RowSource::kPosition, RowSource::kDriveConstants, RowSource::kDriveConstants};
  result.model.reference = data.reference;
  result.model.provenance.created_utc = utc_timestamp();
  return result;
}

std::vector<std::vector<double>> held_out_times(const ExperimentData& force_data, double validation_fraction) {
  std::vector<std::vector<double>> times;
  for (const auto& experiment : force_data.coil_sets) {
    const auto split = identification::split_contiguous_blocks(experiment.dataset, validation_fraction);
    std::vector<double>& held = times.emplace_back();
    for (const Eigen::Index k : split.validation) held.push_back(experiment.motion.time_s[k]);
    std::sort(held.begin(), held.end());
  }
  return times;
}

ElectromagneticModel position_model_without(const ExperimentData& data, const MotorDescription& motor,
                                            const PositionIdentifyOptions& options,
                                            const PositionIdentification& identified,
                                            const std::vector<std::vector<double>>& excluded_times_s) {
  if (excluded_times_s.size() != data.coil_sets.size()) {
    throw std::invalid_argument("position model without held-out rows: " + std::to_string(excluded_times_s.size()) +
                                " coil sets of excluded times for " + std::to_string(data.coil_sets.size()));
  }
  identification::MotionFitOptions fit = with_drive(options.motion, motor);
  fit.mass_kg = identified.mass_kg;  // the scale of the model kept
  fit.viscous_N_s_per_m = fit.direction_N = 0.0;
  const UniformCubicBasis& basis = identified.model.model.spline_basis;
  std::vector<std::vector<identification::MotionRun>> training(data.coil_sets.size());
  for (std::size_t l = 0; l < data.coil_sets.size(); ++l) {
    for (const auto& run : data.coil_sets[l].runs) {
      const Eigen::Index n = run.time_s.size();
      // Half a period: the rows of both tables carry the same cycles' times.
      const double tolerance_s = n > 1 ? 0.5 * (run.time_s[n - 1] - run.time_s[0]) / static_cast<double>(n - 1) : 0.0;
      cut_at(run, excluded_times_s[l], tolerance_s, training[l]);
    }
  }
  return spline_model(fit_all(training, data, motor, basis, fit), basis, motor,
                      identified.model.model.normalisation);
}

identification::PayloadMass mass_from_payload(const ExperimentData& without, const ExperimentData& with,
                                              const MotorDescription& motor, const PositionIdentifyOptions& options,
                                              double payload_kg) {
  if (without.coil_sets.size() != with.coil_sets.size()) {
    throw std::runtime_error(with.origin + ": " + std::to_string(with.coil_sets.size()) + " coil sets, " +
                             without.origin + ": " + std::to_string(without.coil_sets.size()));
  }
  std::vector<double> compared, positions;
  append_positions(without, compared);
  positions = compared;
  append_positions(with, positions);
  identification::SplineOptions grid;
  grid.knot_spacing_m = motor.pole_pitch_m / 8.0;
  const UniformCubicBasis basis = identification::spline_basis_for(as_vector(positions), motor.pole_pitch_m, grid);
  // Per kilogram: the mass given as 1, no friction prior.
  identification::MotionFitOptions per_kg = with_drive(options.motion, motor);
  per_kg.mass_kg = 1.0;
  per_kg.viscous_N_s_per_m = per_kg.direction_N = 0.0;
  const auto fits_of = [&](const ExperimentData& data) {
    std::vector<std::vector<identification::MotionRun>> runs;
    for (const auto& experiment : data.coil_sets) runs.push_back(experiment.runs);
    return fit_all(runs, data, motor, basis, per_kg);
  };
  const auto fits_without = fits_of(without), fits_with = fits_of(with);
  try {
    return identification::mass_from_payload(fits_without, fits_with, payload_kg, as_vector(compared),
                                             motor.pole_pitch_m, basis);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(without.origin + " and " + with.origin + ": " + e.what());
  }
}

void take_off_axis_rows(ModelFile& position_model, const ModelFile& force_model) {
  ElectromagneticModel& into = position_model.model;
  const ElectromagneticModel& from = force_model.model;
  const auto& a = into.spline_basis;
  const auto& b = from.spline_basis;
  if (from.kind != ModelKind::kSpline || into.kind != ModelKind::kSpline) {
    throw std::invalid_argument("off-axis rows: both models must be splines");
  }
  if (from.coil_set_count() != into.coil_set_count() || a.start_m != b.start_m || a.end_m != b.end_m ||
      a.intervals != b.intervals) {
    throw std::invalid_argument("off-axis rows: the models differ in coil sets or knot grid");
  }
  for (std::size_t l = 0; l < into.coil_sets.size(); ++l) {
    CoilSetModel& to = into.coil_sets[l];
    const CoilSetModel& source = from.coil_sets[l];
    to.a_N_per_A.bottomRows<2>() = source.a_N_per_A.bottomRows<2>();
    to.b_N_per_A.bottomRows<2>() = source.b_N_per_A.bottomRows<2>();
    to.column_a_spline.bottomRows<2>() = source.column_a_spline.bottomRows<2>();
    to.column_b_spline.bottomRows<2>() = source.column_b_spline.bottomRows<2>();
    to.cogging_spline.bottomRows<2>() = source.cogging_spline.bottomRows<2>();
  }
  into.validate();
  position_model.provenance.rows_from = {RowSource::kPosition, RowSource::kForceSensor, RowSource::kForceSensor};
}

void reconstruct_driving_force(ExperimentData& data, const MotorDescription& motor,
                               const PositionIdentification& identified) {
  const UniformCubicBasis& basis = identified.model.model.spline_basis;
  for (std::size_t l = 0; l < data.coil_sets.size(); ++l) {
    auto& experiment = data.coil_sets[l];
    const auto& set = experiment.dataset;
    for (auto& forces : experiment.driving_force_N) forces.clear();
    for (Eigen::Index k = 0; k < set.size(); ++k) {
      const double force_N =
          identified.fits[l].gain(set.position_m[k], motor.pole_pitch_m, basis).dot(set.currents_A.col(k));
      experiment.driving_force_N[static_cast<std::size_t>(set.group[static_cast<std::size_t>(k)])].push_back(force_N);
    }
  }
}

double position_validation_score(const ExperimentData& data, const IdentifyOptions& options,
                                 const IdentifySummary& summary, const std::vector<CoilSetIdentification>& reports,
                                 const ElectromagneticModel& model, HeldOutBlocks* blocks) {
  if (blocks != nullptr) blocks->clear();
  if (!data.measured_forces || reports.size() != data.coil_sets.size() || summary.trials.empty()) {
    return std::nan("");
  }
  const double smoothing_m_per_s =
      summary.trials[summary.chosen].model.provenance.nuisance.direction_smoothing_m_per_s;
  double score = 0.0;
  HeldOutBlocks per_block;
  for (std::size_t l = 0; l < data.coil_sets.size(); ++l) {
    identification::CoilSetDataset dataset = data.coil_sets[l].dataset;
    if (summary.nuisance) dataset.wrench.row(0).array() -= summary.sensor_offset.offset_N;
    const auto split = identification::split_contiguous_blocks(dataset, options.validation_fraction);
    if (split.validation.empty()) return std::nan("");
    // F_y − the model's F_y, and the shape of the direction-dependent force.
    const auto residual = [&](Eigen::Index k, double& shape) {
      CoilGain gain;
      Wrench cogging;
      model.evaluate_coil_set(static_cast<int>(l), dataset.position_m[k], gain, cogging);
      const bool direction = summary.direction_force && dataset.velocity_m_per_s.size() == dataset.size();
      shape = direction ? elementary::tanh(dataset.velocity_m_per_s[k] / smoothing_m_per_s) : 0.0;
      return dataset.wrench(0, k) - gain.row(0).dot(dataset.currents_A.col(k)) - cogging[0];
    };
    double cross = 0.0, square = 0.0, shape = 0.0;
    for (const Eigen::Index k : split.training) {
      const double r = residual(k, shape);
      cross += r * shape;
      square += shape * shape;
    }
    const double direction_N = square > 0.0 ? cross / square : 0.0;
    double held_out = 0.0;
    Eigen::VectorXd squares(static_cast<Eigen::Index>(split.validation.size()));
    for (std::size_t v = 0; v < split.validation.size(); ++v) {
      const double r = residual(split.validation[v], shape) - direction_N * shape;
      squares[static_cast<Eigen::Index>(v)] = r * r;
      held_out += r * r;
    }
    held_out /= static_cast<double>(split.validation.size());
    const double physics = reports[l].report.physics_validation[0];
    if (!(physics > 0.0)) return std::nan("");
    score += held_out / physics;
    // The physics-only fit's per-sample errors on the same blocks, when the
    // reports carry them (an identification with held-out data).
    const auto& physics_N2 = reports[l].report.physics_validation_y_N2;
    if (physics_N2.size() == squares.size()) {
      per_block.push_back(held_out_blocks(squares, physics_N2, split.validation_blocks));
    }
  }
  if (blocks != nullptr && per_block.size() == data.coil_sets.size()) *blocks = std::move(per_block);
  return score;
}

}  // namespace clm::data
