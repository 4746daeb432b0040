#include "tools/data/commissioning_steps.hpp"

#include <ctime>
#include <stdexcept>

#include "commutation/calibration.hpp"
#include "commutation/identification/linear_parameters.hpp"

namespace clm::data {

CalibrationFile calibrate_motor(const ExperimentData& data, const MotorDescription& motor, CalibrationMethod method) {
  CalibrationFile file;
  file.pole_pitch_m = motor.pole_pitch_m;
  file.drive = motor.drive;
  file.method = method == CalibrationMethod::kAlgorithm1 ? "algorithm1" : "offset_robust";
  for (const auto& experiment : data.coil_sets) {
    const CalibrationGroup first{experiment.delta_rad[0], experiment.position_m[0], experiment.magnitude_N[0],
                                 experiment.driving_force_N[0]};
    const CalibrationGroup second{experiment.delta_rad[1], experiment.position_m[1], experiment.magnitude_N[1],
                                  experiment.driving_force_N[1]};
    CalibrationResult result;
    try {
      if (method == CalibrationMethod::kAlgorithm1) {
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
    file.coil_sets.push_back(entry);
  }
  file.created_utc = utc_timestamp();
  return file;
}

ModelFile identify_motor(const ExperimentData& data, const MotorDescription& motor, const IdentifyOptions& options,
                         std::vector<CoilSetIdentification>& reports,
                         const std::function<void(const IdentifyProgress&)>& progress) {
  ModelFile file;
  auto& model = file.model;
  model.kind = options.kind;
  model.pole_pitch_m = motor.pole_pitch_m;
  // One normalisation and one knot grid for the whole model, from all positions.
  Eigen::Index total = 0;
  for (const auto& experiment : data.coil_sets) total += experiment.dataset.size();
  Eigen::VectorXd all_positions(total);
  Eigen::Index at = 0;
  for (const auto& experiment : data.coil_sets) {
    all_positions.segment(at, experiment.dataset.size()) = experiment.dataset.position_m;
    at += experiment.dataset.size();
  }
  model.normalisation = identification::normalisation_for(all_positions);
  model.spline_basis = identification::spline_basis_for(all_positions, motor.pole_pitch_m, options.spline);

  reports.clear();
  const int count = static_cast<int>(data.coil_sets.size());
  for (const auto& experiment : data.coil_sets) {
    const auto split = identification::split_contiguous_blocks(experiment.dataset, options.validation_fraction);
    const auto training = experiment.dataset.subset(split.training);
    const auto validation = experiment.dataset.subset(split.validation);
    CoilSetIdentification entry;
    entry.training_samples = split.training.size();
    entry.validation_samples = split.validation.size();
    CoilSetModel part;
    if (options.kind == ModelKind::kPgnn) {
      identification::PgnnOptions pgnn = options.pgnn;
      pgnn.seed = options.pgnn.seed + static_cast<std::uint64_t>(experiment.coil_set) * 1000;
      const auto on_step = [&](const identification::PgnnProgress& p) {
        if (progress) progress({experiment.coil_set, count, p.restart + 1, p.restarts + 1});
      };
      part = identification::identify_pgnn_coil_set(training, validation, motor.pole_pitch_m, model.normalisation,
                                                    pgnn, entry.report, on_step);
    } else {
      part = identification::identify_spline_coil_set(training, validation, motor.pole_pitch_m, model.spline_basis,
                                                      options.spline, entry.report);
      if (progress) progress({experiment.coil_set, count, 1, 1});
    }
    model.coil_sets.push_back(std::move(part));
    CoilSetCosts costs;
    for (std::size_t q = 0; q < 3; ++q) {
      const auto i = static_cast<Eigen::Index>(q);
      costs.physics_training[q] = entry.report.physics_training[i];
      costs.model_training[q] = entry.report.model_training[i];
      costs.physics_validation[q] = entry.report.physics_validation[i];
      costs.model_validation[q] = entry.report.model_validation[i];
    }
    file.provenance.costs.push_back(costs);
    reports.push_back(entry);
  }
  model.validate();
  file.provenance.created_utc = utc_timestamp();
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
