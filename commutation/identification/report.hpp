#pragma once
// What an identification reports: the data-term costs of the identified model
// and of the physics-only fit on training and validation data, and whether
// Proposition 4.1 (eq. 32) holds. Shared by the PGNN and the spline fits. No I/O.

#include "commutation/identification/dataset.hpp"
#include "commutation/model.hpp"

namespace clm::identification {

struct IdentificationReport {
  DirectionCost physics_training = DirectionCost::Zero();
  DirectionCost model_training = DirectionCost::Zero();
  DirectionCost physics_validation = DirectionCost::Zero();
  DirectionCost model_validation = DirectionCost::Zero();
  double regularised_cost = 0.0;  ///< eq. (26) of the final model on training data
  int best_restart = -1;
  int iterations = 0;             ///< LM iterations over all steps
  /// Proposition 4.1 per direction: the model's training data term does not
  /// exceed the physics-only one (eq. 32).
  bool proposition_holds[3] = {false, false, false};
};

/// Data-term cost per direction (mean squared error, eq. 26 without the
/// regularisation) of coil set `coil_set` of `model` on `data`. Evaluates the
/// model through ElectromagneticModel, independently of the training code.
DirectionCost coil_set_cost(const ElectromagneticModel& model, int coil_set, const CoilSetDataset& data);

/// A model of kind `kind` holding `coil_set` as its only coil set, so that
/// coil_set_cost can evaluate a coil set identified on its own.
ElectromagneticModel single_coil_set_model(ModelKind kind, double pole_pitch_m,
                                           const PositionNormalisation& normalisation,
                                           const UniformCubicBasis& basis, const CoilSetModel& coil_set);

/// Fills the four costs of `report` (validation ones only for non-empty
/// `validation`) and proposition_holds, from the single-coil-set `model` and
/// the physics-only `physics` model.
void fill_report_costs(const ElectromagneticModel& model, const ElectromagneticModel& physics,
                       const CoilSetDataset& training, const CoilSetDataset& validation, IdentificationReport& report);

}  // namespace clm::identification
