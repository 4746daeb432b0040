#include "commutation/identification/report.hpp"

namespace clm::identification {

DirectionCost coil_set_cost(const ElectromagneticModel& model, int coil_set, const CoilSetDataset& data) {
  DirectionCost cost = DirectionCost::Zero();
  if (data.size() == 0) return cost;
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    CoilGain gain;
    Wrench cogging;
    model.evaluate_coil_set(coil_set, data.position_m[t], gain, cogging);
    const Wrench error = data.wrench.col(t) - gain * data.currents_A.col(t) - cogging;
    cost += error.cwiseAbs2();
  }
  return cost / static_cast<double>(data.size());
}

ElectromagneticModel single_coil_set_model(ModelKind kind, double pole_pitch_m, const PositionNormalisation& normalisation,
                                           const UniformCubicBasis& basis, const CoilSetModel& coil_set) {
  ElectromagneticModel model;
  model.kind = kind;
  model.pole_pitch_m = pole_pitch_m;
  model.normalisation = normalisation;
  model.spline_basis = basis;
  model.coil_sets.push_back(coil_set);
  return model;
}

void fill_report_costs(const ElectromagneticModel& model, const ElectromagneticModel& physics,
                       const CoilSetDataset& training, const CoilSetDataset& validation, IdentificationReport& report) {
  report.model_training = coil_set_cost(model, 0, training);
  report.physics_training = coil_set_cost(physics, 0, training);
  if (validation.size() > 0) {
    report.model_validation = coil_set_cost(model, 0, validation);
    report.physics_validation = coil_set_cost(physics, 0, validation);
  }
}

void fill_fit_costs(const ElectromagneticModel& model, const ElectromagneticModel& physics, const CoilSetDataset& fitted,
                    IdentificationReport& report) {
  report.model_fit = coil_set_cost(model, 0, fitted);
  report.physics_fit = coil_set_cost(physics, 0, fitted);
  for (int q = 0; q < 3; ++q) {
    report.proposition_holds[q] = report.model_fit[q] <= report.physics_fit[q] * (1.0 + 1e-9) + 1e-12;
  }
}

}  // namespace clm::identification
