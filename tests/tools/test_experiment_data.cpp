// Experiment rows into calibration and identification data
// (docs/commissioning.md, "Experiment data"): a row's force is paired with
// the setpoint of the row before it, the previous cycle of the same run, at
// its own position; rows without a previous cycle are left out.
#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "commutation/classical.hpp"
#include "tools/data/csv_table.hpp"
#include "tools/data/experiment_data.hpp"

using namespace clm;
using namespace clm::data;

namespace {

struct Row {
  double t_s, delta_rad, magnitude_N, y_m, fy_N;
  std::vector<double> currents_A = {};  // ia_A, ib_A when given
};

std::string csv(const std::vector<Row>& rows, bool currents = false, bool forces = true) {
  std::ostringstream out;
  out.precision(17);
  out << "t_s,coil_set,delta_rad,magnitude_N,y_m" << (forces ? ",Fy_N,Fx_N,Tz_Nm" : "")
      << (currents ? ",ia_A,ib_A" : "") << "\n";
  for (const Row& r : rows) {
    out << r.t_s << ",1," << r.delta_rad << "," << r.magnitude_N << "," << r.y_m;
    if (forces) out << "," << r.fy_N << ",0.5,0.25";
    if (currents) out << "," << r.currents_A[0] << "," << r.currents_A[1];
    out << "\n";
  }
  return out.str();
}

MotorDescription one_coil_set() {
  MotorDescription motor;
  motor.pole_pitch_m = 0.03;
  motor.coil_sets = 1;
  motor.drive = {60.0, -0.5};
  return motor;
}

}  // namespace

TEST_CASE("each force is paired with the previous cycle's setpoint at its own position", "[experiment_data]") {
  // Two runs of five cycles, one per offset, a second apart.
  std::vector<Row> rows;
  for (int g = 0; g < 2; ++g) {
    for (int k = 0; k < 5; ++k) {
      rows.push_back({g * 1.0 + k * 1e-3, g == 0 ? -0.75 : 0.75, 10.0 * (k + 1) + g, 0.01 * k - 0.02, 100.0 * k + g});
    }
  }
  const MotorDescription motor = one_coil_set();
  const ExperimentData data = read_experiment_data(CsvTable::parse(csv(rows), "data.csv"), motor);
  CHECK(data.unpaired_rows == 2);  // the first cycle of each run
  const CoilSetExperiment& experiment = data.coil_sets[0];
  REQUIRE(experiment.dataset.size() == 8);
  for (int g = 0; g < 2; ++g) {
    const auto group = static_cast<std::size_t>(g);
    REQUIRE(experiment.position_m[group].size() == 4);
    for (std::size_t k = 1; k < 5; ++k) {
      const Row& row = rows[5 * group + k];
      const Row& before = rows[5 * group + k - 1];
      CHECK(experiment.position_m[group][k - 1] == row.y_m);
      CHECK(experiment.driving_force_N[group][k - 1] == row.fy_N);
      CHECK(experiment.magnitude_N[group][k - 1] == before.magnitude_N);
      const auto t = static_cast<Eigen::Index>(4 * group + k - 1);
      const Eigen::Vector2d expected =
          drive_phase_currents(motor.drive, {before.magnitude_N, before.delta_rad}, row.y_m, motor.pole_pitch_m);
      CHECK(experiment.dataset.currents_A(0, t) == Approx(expected[0]).margin(1e-12));
      CHECK(experiment.dataset.currents_A(1, t) == Approx(expected[1]).margin(1e-12));
      CHECK(experiment.dataset.wrench(0, t) == row.fy_N);
      CHECK(experiment.dataset.position_m[t] == row.y_m);
    }
  }
}

TEST_CASE("currents sent to a phase-current drive pair the same way, and a gap in time starts a new run",
          "[experiment_data]") {
  std::vector<Row> rows;
  // Offset −0.75: cycles at 0, 1, 2 ms, then a gap, then 500 and 501 ms.
  for (const double t : {0.0, 1e-3, 2e-3, 0.5, 0.501}) rows.push_back({t, -0.75, 1.0, t, 10.0 * t, {t, -t}});
  for (const double t : {2.0, 2.001}) rows.push_back({t, 0.75, 1.0, 0.0, 1.0, {1.0, 2.0}});
  const ExperimentData data =
      read_experiment_data(CsvTable::parse(csv(rows, true), "data.csv"), one_coil_set());
  CHECK(data.unpaired_rows == 3);  // t = 0, 0.5 and 2.0
  const auto& set = data.coil_sets[0].dataset;
  REQUIRE(set.size() == 4);
  // Rows 1, 2 and 4 of the first offset with the currents of rows 0, 1 and 3.
  CHECK(set.currents_A(0, 0) == 0.0);
  CHECK(set.currents_A(0, 1) == 1e-3);
  CHECK(set.currents_A(0, 2) == 0.5);
  CHECK(set.position_m[2] == 0.501);
}

TEST_CASE("an offset without two consecutive cycles is refused naming file and column", "[experiment_data]") {
  // Every row of the second offset stands alone (steps of 1 s against the 1 ms of the first).
  std::vector<Row> rows;
  for (int k = 0; k < 5; ++k) rows.push_back({k * 1e-3, -0.75, 1.0, 0.0, 1.0});
  for (int k = 0; k < 3; ++k) rows.push_back({10.0 + k, 0.75, 1.0, 0.0, 1.0});
  try {
    read_experiment_data(CsvTable::parse(csv(rows), "data.csv"), one_coil_set());
    FAIL("not refused");
  } catch (const std::runtime_error& e) {
    CHECK_THAT(e.what(), Catch::StartsWith("data.csv: column 't_s': coil set 1, offset 0.75 rad: no two consecutive"));
  }
}

TEST_CASE("without force columns the rows are runs of consecutive cycles, each setpoint at its period's middle",
          "[experiment_data]") {
  // Offset −0.75: cycles at 0, 1, 2 ms, a gap, 500 and 501 ms; offset 0.75: 2.0 and 2.001 s.
  std::vector<Row> rows;
  for (const double t : {0.0, 1e-3, 2e-3, 0.5, 0.501}) rows.push_back({t, -0.75, 10.0 + t, 0.1 * t, 0.0});
  for (const double t : {2.0, 2.001}) rows.push_back({t, 0.75, 5.0, 0.01 + t, 0.0});
  const MotorDescription motor = one_coil_set();
  const ExperimentData data = read_experiment_data(CsvTable::parse(csv(rows, false, false), "data.csv"), motor);
  CHECK_FALSE(data.measured_forces);
  const CoilSetExperiment& experiment = data.coil_sets[0];
  CHECK(experiment.dataset.wrench.cols() == 0);
  CHECK(experiment.driving_force_N[0].empty());
  // Every row in exactly one run, in order: [0, 1, 2], [3, 4], [5, 6].
  const std::vector<std::vector<std::size_t>> expected_runs = {{0, 1, 2}, {3, 4}, {5, 6}};
  REQUIRE(experiment.runs.size() == expected_runs.size());
  for (std::size_t j = 0; j < expected_runs.size(); ++j) {
    const auto& run = experiment.runs[j];
    const auto& members = expected_runs[j];
    REQUIRE(static_cast<std::size_t>(run.position_m.size()) == members.size());
    for (std::size_t k = 0; k < members.size(); ++k) {
      const Row& row = rows[members[k]];
      const auto i = static_cast<Eigen::Index>(k);
      CHECK(run.time_s[i] == row.t_s);
      CHECK(run.position_m[i] == row.y_m);
      // The row's own setpoint over the period after it, at that period's
      // middle position; the last row of a run at its own.
      const double at_m = k + 1 < members.size() ? 0.5 * (row.y_m + rows[members[k + 1]].y_m) : row.y_m;
      const Eigen::Vector2d expected =
          drive_phase_currents(motor.drive, {row.magnitude_N, row.delta_rad}, at_m, motor.pole_pitch_m);
      CHECK(run.currents_A(0, i) == Approx(expected[0]).margin(1e-12));
      CHECK(run.currents_A(1, i) == Approx(expected[1]).margin(1e-12));
    }
  }
}

TEST_CASE("one or two force columns without the others are refused", "[experiment_data]") {
  const std::string header = "t_s,coil_set,delta_rad,magnitude_N,y_m,Fy_N\n";
  try {
    read_experiment_data(CsvTable::parse(header + "0,1,-0.75,1,0,1\n0.001,1,0.75,1,0,1\n", "data.csv"),
                         one_coil_set());
    FAIL("not refused");
  } catch (const std::runtime_error& e) {
    CHECK_THAT(e.what(), Catch::StartsWith("data.csv:1: missing column 'Fx_N': the force columns"));
  }
}
