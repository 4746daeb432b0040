#include "commutation/identification/report.hpp"

namespace clm::identification {

namespace {

/// Measured wrench − the model's at sample t: the one residual both the cost
/// and the per-sample errors are made of.
Wrench residual(const ElectromagneticModel& model, int coil_set, const CoilSetDataset& data,
                const DirectionForce& direction, bool nuisance, Eigen::Index t) {
  CoilGain gain;
  Wrench cogging;
  model.evaluate_coil_set(coil_set, data.position_m[t], gain, cogging);
  Wrench error = data.wrench.col(t) - gain * data.currents_A.col(t) - cogging;
  if (nuisance) error -= direction.amplitude * direction.feature(data.velocity_m_per_s[t]);
  return error;
}

bool has_nuisance(const CoilSetDataset& data, const DirectionForce& direction) {
  return direction.identified() && data.velocity_m_per_s.size() == data.size();
}

}  // namespace

DirectionCost coil_set_cost(const ElectromagneticModel& model, int coil_set, const CoilSetDataset& data,
                            const DirectionForce& direction) {
  DirectionCost cost = DirectionCost::Zero();
  if (data.size() == 0) return cost;
  const bool nuisance = has_nuisance(data, direction);
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    cost += residual(model, coil_set, data, direction, nuisance, t).cwiseAbs2();
  }
  return cost / static_cast<double>(data.size());
}

Eigen::VectorXd coil_set_squared_errors(const ElectromagneticModel& model, int coil_set, const CoilSetDataset& data,
                                        int direction, const DirectionForce& direction_force) {
  Eigen::VectorXd squares(data.size());
  const bool nuisance = has_nuisance(data, direction_force);
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    const Wrench error = residual(model, coil_set, data, direction_force, nuisance, t);
    squares[t] = error[direction] * error[direction];
  }
  return squares;
}

ElectromagneticModel single_coil_set_model(ModelKind kind, double pole_pitch_m, const PositionNormalisation& normalisation,
                                           const UniformCubicBasis& basis, const CoilSetModel& coil_set,
                                           const HarmonicOrders& harmonics) {
  ElectromagneticModel model;
  model.harmonics = harmonics;
  model.kind = kind;
  model.pole_pitch_m = pole_pitch_m;
  model.normalisation = normalisation;
  model.spline_basis = basis;
  model.coil_sets.push_back(coil_set);
  return model;
}

void fill_report_costs(const ModelWithNuisance& model, const ModelWithNuisance& physics, const CoilSetDataset& training,
                       const CoilSetDataset& validation, IdentificationReport& report) {
  report.model_training = coil_set_cost(model.model, 0, training, model.direction);
  report.physics_training = coil_set_cost(physics.model, 0, training, physics.direction);
  if (validation.size() > 0) {
    report.model_validation = coil_set_cost(model.model, 0, validation, model.direction);
    report.physics_validation = coil_set_cost(physics.model, 0, validation, physics.direction);
    report.model_validation_y_N2 = coil_set_squared_errors(model.model, 0, validation, 0, model.direction);
    report.physics_validation_y_N2 = coil_set_squared_errors(physics.model, 0, validation, 0, physics.direction);
  }
}

void fill_fit_costs(const ModelWithNuisance& model, const ModelWithNuisance& physics, const CoilSetDataset& fitted,
                    IdentificationReport& report) {
  report.model_fit = coil_set_cost(model.model, 0, fitted, model.direction);
  report.physics_fit = coil_set_cost(physics.model, 0, fitted, physics.direction);
  report.direction_force = model.direction;
  report.physics_direction_force = physics.direction;
  for (int q = 0; q < 3; ++q) {
    report.proposition_holds[q] = report.model_fit[q] <= report.physics_fit[q] * (1.0 + 1e-9) + 1e-12;
  }
}

}  // namespace clm::identification
