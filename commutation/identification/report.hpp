#pragma once
// What an identification reports: the data-term costs of the model fit on the
// training data alone and of the physics-only fit, on training and held-out
// validation data; those of the model put to use, fit on every sample; and
// whether Proposition 4.1 (eq. 32) holds for it. Shared by the PGNN and the
// spline fits. No I/O.

#include "commutation/identification/dataset.hpp"
#include "commutation/identification/excitation.hpp"
#include "commutation/identification/nuisance.hpp"
#include "commutation/model.hpp"

namespace clm::identification {

struct IdentificationReport {
  // The model and the physics-only fit identified on the training data alone:
  // on them, and on the held-out validation data (the estimate of how the
  // model predicts what it has not seen).
  DirectionCost physics_training = DirectionCost::Zero();
  DirectionCost model_training = DirectionCost::Zero();
  DirectionCost physics_validation = DirectionCost::Zero();
  DirectionCost model_validation = DirectionCost::Zero();
  /// The squared F_y errors [N²] of the model and of the physics-only fit on
  /// every held-out sample, in the order of the validation data (their means
  /// are model_validation[0] and physics_validation[0]): summed per held-out
  /// block, they give the validation score's uncertainty
  /// (tools/data/held_out_score.hpp). Empty without validation data.
  Eigen::VectorXd model_validation_y_N2;
  Eigen::VectorXd physics_validation_y_N2;
  /// The model put to use: with validation data it is fit once more on
  /// training and validation data together (refit_on_all_data), else it is
  /// the training-only model. Its data terms, and the physics-only fit's, on
  /// the data it was fit on.
  bool refit_on_all_data = false;
  DirectionCost physics_fit = DirectionCost::Zero();
  DirectionCost model_fit = DirectionCost::Zero();
  double regularised_cost = 0.0;  ///< eq. (26) of the model put to use, on the data it was fit on
  /// The direction-dependent force identified beside the model put to use
  /// (Remark 5.1; reported, never part of the commutation law), and beside
  /// the physics-only fit of the same data.
  DirectionForce direction_force;
  DirectionForce physics_direction_force;
  /// The model put to use: its linear parameters' regressors on the data
  /// it was fit on, and the stretches of the stroke those data do not excite.
  RegressorQuality regressors;
  std::vector<ExcitationGap> excitation_gaps;
  int best_restart = -1;
  int iterations = 0;             ///< LM iterations over all steps
  /// Proposition 4.1 per direction for the model put to use: its data term
  /// does not exceed the physics-only one on the data both were fit on (eq. 32).
  bool proposition_holds[3] = {false, false, false};
};

/// Data-term cost per direction (mean squared error, eq. 26 without the
/// regularisation) of coil set `coil_set` of `model` on `data`, with the
/// direction-dependent force `direction` identified beside it added to the
/// prediction. Evaluates the model through ElectromagneticModel,
/// independently of the training code.
DirectionCost coil_set_cost(const ElectromagneticModel& model, int coil_set, const CoilSetDataset& data,
                            const DirectionForce& direction = {});

/// The squared error in direction `direction` (0 y, 1 x, 2 z) of every
/// sample of `data`, in its order: the terms whose mean is coil_set_cost.
Eigen::VectorXd coil_set_squared_errors(const ElectromagneticModel& model, int coil_set, const CoilSetDataset& data,
                                        int direction, const DirectionForce& direction_force = {});

/// A model with the direction-dependent force identified beside it.
struct ModelWithNuisance {
  const ElectromagneticModel& model;
  const DirectionForce& direction;
};

/// A model of kind `kind` holding `coil_set` as its only coil set, so that
/// coil_set_cost can evaluate a coil set identified on its own; a PGNN's
/// physics part carries `harmonics`.
ElectromagneticModel single_coil_set_model(ModelKind kind, double pole_pitch_m,
                                           const PositionNormalisation& normalisation,
                                           const UniformCubicBasis& basis, const CoilSetModel& coil_set,
                                           const HarmonicOrders& harmonics = {});

/// Fills the training and validation costs of `report` (validation ones only
/// for non-empty `validation`) from the single-coil-set `model` and the
/// physics-only `physics` model, both fit on `training` alone.
void fill_report_costs(const ModelWithNuisance& model, const ModelWithNuisance& physics, const CoilSetDataset& training,
                       const CoilSetDataset& validation, IdentificationReport& report);

/// Fills model_fit, physics_fit and proposition_holds from the model put to
/// use and the physics-only model, both fit on `fitted`.
void fill_fit_costs(const ModelWithNuisance& model, const ModelWithNuisance& physics, const CoilSetDataset& fitted,
                    IdentificationReport& report);

}  // namespace clm::identification
