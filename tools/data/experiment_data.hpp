#pragma once
// Experiment data of the tools (docs/data-formats.md): each coil set driven
// alone with two phase offsets, as a CSV with columns
// t_s, coil_set, delta_rad, magnitude_N, y_m [, Fy_N, Fx_N, Tz_Nm] [, ia_A, ib_A].
// Without the force columns (an axis without a force sensor) the rows are
// motion runs for the position-based identification (position_model.hpp).

#include <array>
#include <string>
#include <vector>

#include "commutation/identification/dataset.hpp"
#include "commutation/identification/motion_fit.hpp"
#include "commutation/identification/nuisance.hpp"
#include "commutation/model_file.hpp"
#include "tools/data/csv_table.hpp"

namespace clm::data {

struct CoilSetExperiment {
  int coil_set = 0;  ///< 1-based
  std::array<double, 2> delta_rad{};
  /// Per offset group: the columns Algorithm 1 needs. Without force columns
  /// driving_force_N stays empty until reconstruct_driving_force fills it.
  std::array<std::vector<double>, 2> position_m, magnitude_N, driving_force_N;
  /// Both groups with currents (measured ia_A/ib_A when present, else
  /// reconstructed through the drive's fixed commutation, eq. 19) and the
  /// velocity from t_s and y_m.
  identification::CoilSetDataset dataset;
  /// The same rows as times, positions and F_y, for the sensor-offset fit.
  identification::MotionRecord motion;
  /// Every row in runs of consecutive cycles, each row's setpoint as the
  /// currents it drives over the period after it (position-based
  /// identification; with force columns too).
  std::vector<identification::MotionRun> runs;
};

struct ExperimentData {
  std::string origin;
  bool measured_currents = false;
  /// Fy_N, Fx_N and Tz_Nm present. Without them `dataset.wrench` and
  /// `motion.force_N` are empty and only the position-based steps apply.
  bool measured_forces = true;
  std::vector<CoilSetExperiment> coil_sets;  ///< index l − 1
  /// Rows whose previous cycle is not in the table (the first row of each
  /// run): their force has no setpoint to pair with, so they are left out.
  std::size_t unpaired_rows = 0;
  /// The frame of the positions (docs/model-format.md, "The encoder
  /// reference"): the CSV does not carry it, the caller that knows the axis
  /// sets it. The files made from these data record it.
  EncoderReference reference;
};

/// Validates and groups the rows. A row's setpoint (magnitude_N, delta_rad,
/// or ia_A/ib_A) is the one its cycle computed, which the drive applies over
/// the period after it; the force of a row is paired with the setpoint of
/// the row before it (the previous cycle of the same run) and with its own
/// position (docs/commissioning.md, "Experiment data"). Throws
/// std::runtime_error with one line naming file, row and column: missing
/// column (the three force columns go together), non-finite value, coil_set not an integer in 1..L, a coil set
/// without rows, without exactly two distinct offsets, or with an offset of
/// no two consecutive cycles.
ExperimentData read_experiment_data(const CsvTable& table, const MotorDescription& motor);

}  // namespace clm::data
