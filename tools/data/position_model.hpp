#pragma once
// Commissioning without a force sensor (docs/commutation.md, "Without a force
// sensor"): the driving direction of every coil set identified from the
// experiments' positions and times jointly with the translator's mechanics
// (identification::fit_driving_direction_from_motion), and Algorithm 1 run on
// the driving force that model reconstructs. No file I/O.

#include <optional>
#include <utility>
#include <vector>

#include "commutation/identification/motion_fit.hpp"
#include "commutation/model_file.hpp"
#include "tools/data/commissioning_steps.hpp"
#include "tools/data/experiment_data.hpp"

namespace clm::data {

struct PositionIdentifyOptions {
  /// The fit of every coil set: the force scale (mass, or friction, else the
  /// drive's nominal commutation; one mass for the whole translator, see
  /// identification::common_mass_kg), smoothing, v_d and the slowest rows
  /// used. Its `drive` is ignored: the motor description's is used.
  identification::MotionFitOptions motion;
  /// Knot spacing of the y-row splines; 0: chosen by the held-out force
  /// balance from kSplineKnotsPerPolePitch (pole pitch / 8 when nothing is
  /// held out).
  double knot_spacing_m = 0.0;
  /// Share of every run held out, in contiguous blocks, for the spacing choice.
  double validation_fraction = 0.2;
  /// The knot grid to use instead (a force-sensor spline's, so that its F_x
  /// and T_z rows can join the model: take_off_axis_rows).
  std::optional<UniformCubicBasis> basis;
};

struct PositionIdentification {
  /// A spline model: F_y rows from positions; F_x and T_z rows zero (the
  /// drive's constants say nothing off the driving direction).
  ModelFile model;
  std::vector<identification::MotionFit> fits;  ///< per coil set, at the common mass
  double mass_kg = 0.0;
  bool mass_given = false;
  bool friction_given = false;  ///< the scale from the friction given
  double knot_spacing_m = 0.0;
  /// Knot spacings tried and the held-out RMS of the force balance over all
  /// coil sets [m, N]; empty when the spacing was given.
  std::vector<std::pair<double, double>> spacing_scores;
  std::vector<double> validation_residual_rms_N;  ///< per coil set, of the model kept (NaN without held-out rows)
};

/// Throws std::runtime_error naming the data file when a coil set's runs
/// cannot be fit (too few rows in motion, a singular problem, no mass).
PositionIdentification identify_from_position(const ExperimentData& data, const MotorDescription& motor,
                                              const PositionIdentifyOptions& options);

/// The times of the rows each coil set's force models hold out
/// (identification::split_contiguous_blocks of its dataset at
/// `validation_fraction`), sorted, per coil set.
std::vector<std::vector<double>> held_out_times(const ExperimentData& force_data, double validation_fraction);

/// `identified`'s model fit again on `data` without its rows at
/// `excluded_times_s` (per coil set, as held_out_times gives them; each run
/// is cut there, so no difference reaches across a held-out stretch), on the
/// same knot grid and at the same mass: the model a held-out force score
/// compares with force models fit on their training blocks alone. Throws
/// std::invalid_argument when the coil sets differ, std::runtime_error as
/// identify_from_position.
ElectromagneticModel position_model_without(const ExperimentData& data, const MotorDescription& motor,
                                            const PositionIdentifyOptions& options,
                                            const PositionIdentification& identified,
                                            const std::vector<std::vector<double>>& excluded_times_s);

/// The translator's mass from the same experiments without and with a known
/// payload of `payload_kg` (identification::mass_from_payload): every coil
/// set of both fitted per kilogram on one knot grid (pole pitch / 8 over both
/// data's positions; options.motion's smoothing, v_d and slowest rows), and
/// compared at the positions of `without`. Throws std::runtime_error naming
/// the data when a fit fails or the payload made no difference.
identification::PayloadMass mass_from_payload(const ExperimentData& without, const ExperimentData& with,
                                              const MotorDescription& motor, const PositionIdentifyOptions& options,
                                              double payload_kg);

/// The F_x and T_z rows of `force_model` (a spline model from the force
/// sensor on the same knot grid) into `position_model`, whose rows_from says
/// so. Throws std::invalid_argument naming what differs.
void take_off_axis_rows(ModelFile& position_model, const ModelFile& force_model);

/// Fills every offset group's driving_force_N with the electromagnetic
/// driving force the position model predicts for its rows (gain times the
/// previous cycle's currents; no cogging, friction or direction force), the
/// force Algorithm 1 (calibrate_motor) fits the command to.
void reconstruct_driving_force(ExperimentData& data, const MotorDescription& motor,
                               const PositionIdentification& identified);

/// A model from positions, fit without the force data's held-out rows
/// (position_model_without), scored on force data as identify_motor scores
/// its capacity trials (CapacityTrial::validation_score): the sum over coil sets
/// of its held-out F_y MSE over the physics-only fit's, on the same held-out
/// blocks, with the sensor offset of `summary` removed and, where the force
/// models carry one, a direction-dependent force C·tanh(ẏ/v_c) fitted to its
/// residual on the training blocks. `reports` are the chosen force model's
/// (their physics-only figures). NaN without held-out blocks. `blocks`
/// (optional) receives the per-block errors of the same score (its physics
/// errors the reports' own), for its standard error and paired differences
/// (held_out_score.hpp); it is left empty where the score is NaN.
double position_validation_score(const ExperimentData& data, const IdentifyOptions& options,
                                 const IdentifySummary& summary, const std::vector<CoilSetIdentification>& reports,
                                 const ElectromagneticModel& model, HeldOutBlocks* blocks = nullptr);

}  // namespace clm::data
