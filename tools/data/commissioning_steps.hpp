#pragma once
// Whole-motor calibration and identification from experiment data: the steps
// `clm calibrate`, `clm identify` and `clm commission` share. No file I/O;
// progress is reported through a callback.

#include <functional>
#include <string>
#include <vector>

#include "commutation/identification/pgnn_training.hpp"
#include "commutation/identification/report.hpp"
#include "commutation/identification/spline_fit.hpp"
#include "commutation/model_file.hpp"
#include "tools/data/experiment_data.hpp"

namespace clm::data {

enum class CalibrationMethod { kAlgorithm1, kOffsetRobust };

/// Algorithm 1 for every coil set. The offset-robust variant expands the
/// position-dependent offset on a knot grid of spacing pole_pitch/8.
CalibrationFile calibrate_motor(const ExperimentData& data, const MotorDescription& motor, CalibrationMethod method);

struct IdentifyOptions {
  ModelKind kind = ModelKind::kPgnn;
  identification::PgnnOptions pgnn;
  identification::SplineOptions spline;
  double validation_fraction = 0.2;
};

struct IdentifyProgress {
  int coil_set = 0;       ///< 1-based
  int coil_sets = 0;
  int step = 0;           ///< restarts done (PGNN), then one polishing step
  int steps = 0;
};

struct CoilSetIdentification {
  identification::IdentificationReport report;
  std::size_t training_samples = 0;
  std::size_t validation_samples = 0;
};

/// Algorithm 2 (or the spline model) for every coil set; fills the model
/// file's costs. `reports` receives one entry per coil set.
ModelFile identify_motor(const ExperimentData& data, const MotorDescription& motor, const IdentifyOptions& options,
                         std::vector<CoilSetIdentification>& reports,
                         const std::function<void(const IdentifyProgress&)>& progress = {});

/// Current UTC time as 2026-11-21T05:09:41Z.
std::string utc_timestamp();

}  // namespace clm::data
