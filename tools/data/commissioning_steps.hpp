#pragma once
// Whole-motor calibration and identification from experiment data: the steps
// `clm calibrate`, `clm identify` and `clm commission` share. No file I/O;
// progress is reported through a callback.

#include <algorithm>
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "commutation/identification/pgnn_training.hpp"
#include "commutation/identification/report.hpp"
#include "commutation/identification/spline_fit.hpp"
#include "commutation/model_file.hpp"
#include "tools/data/experiment_data.hpp"
#include "tools/data/held_out_score.hpp"

namespace clm::data {

/// kPosition: Algorithm 1 on the driving force of data without force columns
/// that reconstruct_driving_force (position_model.hpp) filled in.
enum class CalibrationMethod { kAlgorithm1, kOffsetRobust, kPosition };

/// Algorithm 1 for every coil set. The offset-robust variant expands the
/// position-dependent offset on a knot grid of spacing pole_pitch/8. Throws
/// std::runtime_error for data whose driving force is neither measured nor
/// reconstructed, or measured data with kPosition.
CalibrationFile calibrate_motor(const ExperimentData& data, const MotorDescription& motor, CalibrationMethod method);

struct IdentifyOptions {
  ModelKind kind = ModelKind::kPgnn;
  identification::PgnnOptions pgnn;
  identification::SplineOptions spline;
  double validation_fraction = 0.2;
  /// Identify the nuisance terms beside the model: the sensor's F_y offset
  /// from the mechanics and the direction-dependent force C·tanh(ẏ/v_c)
  /// (docs/commutation.md, "Nuisance terms"). false: the paper's fit.
  bool nuisance = true;
  /// Choose the capacity (PGNN hidden sizes, spline knot spacing) from the
  /// grid below by validation error; false: pgnn's sizes and spline's
  /// spacing as given.
  bool select_capacity = true;
};

/// The capacities tried: PGNN column and cogging neurons with the Λ of
/// eq. (26) and whether the physics part carries the field harmonics
/// (identification::field_harmonic_orders; the paper's 2/16, 0.1 without
/// them first), and spline knots per pole pitch.
struct PgnnCapacity {
  int column_hidden;
  int cogging_hidden;
  double regularisation;
  bool harmonics;
};
inline constexpr std::array<PgnnCapacity, 3> kPgnnCapacityGrid{
    {{2, 16, 0.1, false}, {4, 16, 0.01, true}, {16, 32, 0.01, true}}};
inline constexpr std::array<int, 5> kSplineKnotsPerPolePitch{4, 6, 8, 12, 16};

struct IdentifyProgress {
  int coil_sets = 0;
  /// Coil sets' worth of the trial's work done, in [0, coil_sets]: the coil
  /// sets are identified side by side, each reporting its share.
  double coil_sets_done = 0.0;
  int trial = 1;          ///< 1-based: which fit of the selection (v_c, then capacities)
  int trials = 1;
  std::string what;       ///< what the trial fits, e.g. "pgnn 4/32"
  /// Share of the whole identification done, in [0, 1].
  double fraction() const {
    return (trial - 1 + coil_sets_done / std::max(coil_sets, 1)) / std::max(trials, 1);
  }
};

struct CoilSetIdentification {
  identification::IdentificationReport report;
  std::size_t training_samples = 0;
  std::size_t validation_samples = 0;
};

/// One capacity tried, fit on training blocks and scored on the held-out ones.
struct CapacityTrial {
  std::string capacity;            ///< "2/16" neurons, or "d_m/8" knot spacing
  int column_hidden = 0, cogging_hidden = 0;  ///< PGNN
  double regularisation = 0.0;                ///< PGNN: Λ of eq. (26)
  bool harmonics = false;                     ///< PGNN: the physics part carries harmonics
  /// The paper's PGNN: 2/16 neurons, Λ = 0.1, no harmonics (always reported).
  bool is_paper_pgnn() const {
    return column_hidden == 2 && cogging_hidden == 16 && regularisation == 0.1 && !harmonics;
  }
  double knot_spacing_m = 0.0;     ///< spline
  /// Σ over coil sets of the model's held-out F_y MSE over the physics-only
  /// fit's (unit-free; lower is better).
  double validation_score = 0.0;
  /// Per coil set, the held-out blocks' F_y squared errors of this trial and
  /// of the physics-only fit, from which the score's standard error and the
  /// paired differences of the recommendation come (held_out_score.hpp);
  /// empty when nothing is held out.
  HeldOutBlocks held_out;
  ModelFile model;
  std::vector<CoilSetIdentification> coil_sets;
};

/// What identify_motor found beside the model.
struct IdentifySummary {
  bool nuisance = false;                  ///< nuisance terms identified
  std::string nuisance_skipped;           ///< why not, when asked for
  bool direction_force = false;           ///< the direction-dependent force identified beside the models
  double direction_force_inflation = 0.0; ///< its largest variance inflation over the coil sets
  std::string direction_force_skipped;    ///< why not, when the nuisance terms were
  identification::DrivingOffsetFit sensor_offset;
  /// v_c tried and the spline validation score of each; the lowest is used.
  std::vector<std::pair<double, double>> direction_smoothing_scores;
  std::vector<CapacityTrial> trials;      ///< in grid order; one entry without selection
  std::size_t chosen = 0;                 ///< index into trials
};

/// Algorithm 2 (or the spline model) for every coil set, with the nuisance
/// terms and the capacity chosen by validation as `options` says (data with
/// force columns; without, identify_from_position); fills the
/// model file's costs and nuisance record. `reports` receives one entry per
/// coil set of the model returned; `summary` (optional) every trial.
ModelFile identify_motor(const ExperimentData& data, const MotorDescription& motor, const IdentifyOptions& options,
                         std::vector<CoilSetIdentification>& reports,
                         const std::function<void(const IdentifyProgress&)>& progress = {},
                         IdentifySummary* summary = nullptr);

/// Current UTC time as 2026-11-21T05:09:41Z.
std::string utc_timestamp();

}  // namespace clm::data
