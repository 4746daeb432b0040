#include "tools/data/experiment_data.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <vector>

#include "commutation/classical.hpp"
#include "commutation/identification/nuisance.hpp"

namespace clm::data {

ExperimentData read_experiment_data(const CsvTable& table, const MotorDescription& motor) {
  const std::string& file = table.origin();
  const auto coil_set = table.numbers("coil_set");
  const auto delta = table.numbers("delta_rad");
  const auto magnitude = table.numbers("magnitude_N");
  const auto position = table.numbers("y_m");
  // The force columns go together: all three (a force sensor) or none.
  const int force_columns = static_cast<int>(table.has("Fy_N")) + static_cast<int>(table.has("Fx_N")) +
                            static_cast<int>(table.has("Tz_Nm"));
  if (force_columns == 1 || force_columns == 2) {
    for (const char* column : {"Fy_N", "Fx_N", "Tz_Nm"}) {
      if (!table.has(column)) {
        throw std::runtime_error(file + ":1: missing column '" + column +
                                 "': the force columns Fy_N, Fx_N and Tz_Nm go together (all, or none without a "
                                 "force sensor)");
      }
    }
  }
  const bool forces = force_columns == 3;
  std::vector<double> fy, fx, tz;
  if (forces) {
    fy = table.numbers("Fy_N");
    fx = table.numbers("Fx_N");
    tz = table.numbers("Tz_Nm");
  }
  const auto time = table.numbers("t_s");
  const bool measured = table.has("ia_A") || table.has("ib_A");
  std::vector<double> ia, ib;
  if (measured) {
    ia = table.numbers("ia_A");
    ib = table.numbers("ib_A");
  }

  // A setpoint acts over the period after the cycle that computed it (the
  // drive holds it until the next): the force measured in row r was made by
  // the setpoint of the cycle before, at row r's position. That cycle is row
  // r − 1 when it belongs to the same run: same coil set and offset, a time
  // step above 0 and at most 1.5 median steps (differentiate's rule). A row
  // without one, the first of each run, carries no usable pair.
  std::vector<double> steps;
  for (std::size_t r = 1; r < table.rows(); ++r) {
    if (time[r] > time[r - 1]) steps.push_back(time[r] - time[r - 1]);
  }
  double median_step_s = 0.0;
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
    median_step_s = steps[steps.size() / 2];
  }

  ExperimentData data;
  data.origin = file;
  data.measured_currents = measured;
  data.measured_forces = forces;
  data.coil_sets.resize(static_cast<std::size_t>(motor.coil_sets));
  std::vector<std::vector<std::size_t>> rows(static_cast<std::size_t>(motor.coil_sets));
  std::vector<int> offsets_seen(static_cast<std::size_t>(motor.coil_sets), 0);
  // The offset group of every row, decided once: a delta_rad within 1e-9 rad
  // of both offsets must land in the same group in the per-group columns and
  // in the dataset (docs/fuzzing.md, fuzz_experiment_data).
  std::vector<int> row_group(table.rows(), 0);
  // Whether row r's previous cycle is row r − 1 (below).
  std::vector<bool> follows(table.rows(), false);
  for (std::size_t r = 0; r < table.rows(); ++r) {
    const double value = coil_set[r];
    if (value != std::floor(value) || value < 1 || value > motor.coil_sets) {
      throw std::runtime_error(table.where(r) + ": column 'coil_set': value " +
                               shortest_double(value) + " is not a coil set of this motor (1.." +
                               std::to_string(motor.coil_sets) + ")");
    }
    const auto l = static_cast<std::size_t>(value) - 1;
    auto& experiment = data.coil_sets[l];
    int group = -1;
    for (int g = 0; g < offsets_seen[l]; ++g) {
      if (std::abs(delta[r] - experiment.delta_rad[static_cast<std::size_t>(g)]) <= 1e-9) group = g;
    }
    if (group < 0) {
      if (offsets_seen[l] == 2) {
        throw std::runtime_error(table.where(r) + ": column 'delta_rad': coil set " +
                                 std::to_string(l + 1) + " has a third phase offset " + shortest_double(delta[r]) +
                                 " rad; each coil set needs exactly two");
      }
      group = offsets_seen[l]++;
      experiment.delta_rad[static_cast<std::size_t>(group)] = delta[r];
    }
    row_group[r] = group;
    follows[r] = r > 0 && coil_set[r - 1] == value && row_group[r - 1] == group && time[r] > time[r - 1] &&
                 time[r] - time[r - 1] <= 1.5 * median_step_s;
    if (!follows[r]) {
      ++data.unpaired_rows;
      continue;
    }
    const auto g = static_cast<std::size_t>(group);
    experiment.position_m[g].push_back(position[r]);
    experiment.magnitude_N[g].push_back(magnitude[r - 1]);
    if (forces) experiment.driving_force_N[g].push_back(fy[r]);
    rows[l].push_back(r);
  }
  // The setpoint of row r as currents: measured, or through the drive's
  // fixed commutation at `position` (eq. 19).
  const auto currents_of = [&](std::size_t r, double at_position_m) -> Eigen::Vector2d {
    if (measured) return {ia[r], ib[r]};
    return drive_phase_currents(motor.drive, {magnitude[r], delta[r]}, at_position_m, motor.pole_pitch_m);
  };
  // Runs of consecutive cycles for the position-based identification: the
  // setpoint of each row drives the period after it, whose middle position
  // its currents are taken at (the last row of a run: its own position), and
  // through a current loop's lag part of the next period, whose middle
  // position its currents are taken at too (motion_fit.hpp, PairingWeights).
  for (std::size_t first = 0; first < table.rows();) {
    std::size_t end = first + 1;
    while (end < table.rows() && follows[end]) ++end;
    identification::MotionRun run;
    const auto n = static_cast<Eigen::Index>(end - first);
    run.time_s.resize(n);
    run.position_m.resize(n);
    run.currents_A.resize(2, n);
    if (!measured) run.currents_next_A.resize(2, n);
    const auto middle_of_period_after = [&](std::size_t r) {
      return r + 1 < end ? 0.5 * (position[r] + position[r + 1]) : position[std::min(r, end - 1)];
    };
    for (Eigen::Index k = 0; k < n; ++k) {
      const std::size_t r = first + static_cast<std::size_t>(k);
      run.time_s[k] = time[r];
      run.position_m[k] = position[r];
      run.currents_A.col(k) = currents_of(r, middle_of_period_after(r));
      if (!measured) run.currents_next_A.col(k) = currents_of(r, middle_of_period_after(r + 1));
    }
    data.coil_sets[static_cast<std::size_t>(coil_set[first]) - 1].runs.push_back(std::move(run));
    first = end;
  }
  for (std::size_t l = 0; l < data.coil_sets.size(); ++l) {
    auto& experiment = data.coil_sets[l];
    experiment.coil_set = static_cast<int>(l + 1);
    if (offsets_seen[l] == 0) {
      throw std::runtime_error(file + ": column 'coil_set': no rows for coil set " + std::to_string(l + 1) +
                               " (the motor has " + std::to_string(motor.coil_sets) + ")");
    }
    if (offsets_seen[l] == 1) {
      throw std::runtime_error(file + ": column 'delta_rad': coil set " + std::to_string(l + 1) +
                               " has a single phase offset (" + shortest_double(experiment.delta_rad[0]) +
                               " rad); calibration and identification need two distinct offsets");
    }
    for (std::size_t g = 0; g < 2; ++g) {
      if (experiment.position_m[g].empty()) {
        throw std::runtime_error(file + ": column 't_s': coil set " + std::to_string(l + 1) + ", offset " +
                                 shortest_double(experiment.delta_rad[g]) +
                                 " rad: no two consecutive cycles (one period apart); the force of a row is made by "
                                 "the setpoint of the row before it");
      }
    }
    auto& set = experiment.dataset;
    const auto n = static_cast<Eigen::Index>(rows[l].size());
    set.position_m.resize(n);
    set.currents_A.resize(2, n);
    set.wrench.resize(3, forces ? n : 0);
    set.group.resize(rows[l].size());
    auto& motion = experiment.motion;
    motion.time_s.resize(n);
    motion.position_m.resize(n);
    motion.force_N.resize(forces ? n : 0);
    for (Eigen::Index k = 0; k < n; ++k) {
      const std::size_t r = rows[l][static_cast<std::size_t>(k)];
      const int group = row_group[r];
      motion.time_s[k] = time[r];
      motion.position_m[k] = position[r];
      set.position_m[k] = position[r];
      // The previous cycle's setpoint, at this row's position (above).
      set.currents_A.col(k) = currents_of(r - 1, position[r]);
      if (forces) {
        motion.force_N[k] = fy[r];
        set.wrench.col(k) << fy[r], fx[r], tz[r];
      }
      set.group[static_cast<std::size_t>(k)] = group;
    }
    // Rows are in time order within each run; the gap between two runs
    // starts a new stretch of the differences.
    set.velocity_m_per_s = identification::differentiate(motion.time_s, motion.position_m);
  }
  return data;
}

}  // namespace clm::data
