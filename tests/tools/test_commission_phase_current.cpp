// `clm commission` in process on the embedded motor behind each drive
// profile (slow tier: a one-stroke experiment program, no held-out run,
// about 8 s per profile). With phase_current the experiment data carry the
// currents the daemon sent, and the PGNN improves on the calibrated
// classical law by the same order as with magnitude_phase.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "commutation/classical.hpp"
#include "support/temporary_directory.hpp"
#include "tools/commission/commission.hpp"
#include "tools/data/csv_table.hpp"
#include "tools/lcmlog/servo_log.hpp"

using namespace clm;

namespace {

std::string source(const std::string& relative) { return std::string(CLM_SOURCE_DIR) + "/" + relative; }

struct Outcome {
  double classical_y = 0.0, pgnn_y = 0.0;
  data::CsvTable experiments;
};

Outcome commission_with(const std::string& config, const test::TemporaryDirectory& directory) {
  commission::Options options;
  options.config_path = source(config);
  options.out_dir = directory.file("commission");
  options.program_path = source("tests/support/one_stroke_program.yaml");
  options.experiment_program_path = options.program_path;  // the unit tier: one stroke for the experiments too
  options.validation_program_path = "none";
  const commission::Report report = commission::run(options);
  Outcome outcome{0.0, 0.0, data::CsvTable::load(options.out_dir + "/experiments.csv")};
  for (const auto& result : report.results) {
    if (result.name == "classical" && result.evaluated) outcome.classical_y = result.mse.filtered[0];
    if (result.name == "pgnn" && result.evaluated) outcome.pgnn_y = result.mse.filtered[0];
  }
  REQUIRE(outcome.classical_y > 0.0);
  REQUIRE(outcome.pgnn_y > 0.0);
  CHECK_FALSE(std::filesystem::exists(options.out_dir + "/" + commission::kIncompleteMarker));
  // Its logs hold the runs only, with the pauses between them marked: no gap.
  for (const auto& entry : std::filesystem::directory_iterator(options.out_dir + "/logs")) {
    INFO(entry.path().string());
    const auto log = lcmlog::read_servo_state_log(entry.path().string());
    CHECK_FALSE(log.gaps.any());
    if (entry.path().filename() == "experiments.lcm") CHECK(log.gaps.cycles.pauses == 2 * 3 - 1);  // 3 coil sets
  }
  return outcome;
}

}  // namespace

TEST_CASE("commissioning behind a phase-current drive improves on classical as much as behind a magnitude/phase drive",
          "[commission][phase_current]") {
  const test::TemporaryDirectory magnitude_dir("clm-commission-magnitude-phase");
  const test::TemporaryDirectory current_dir("clm-commission-phase-current");
  const Outcome magnitude = commission_with("config/servod.yaml", magnitude_dir);
  const Outcome current = commission_with("config/servod-phase-current.yaml", current_dir);
  const double magnitude_ratio = magnitude.classical_y / magnitude.pgnn_y;
  const double current_ratio = current.classical_y / current.pgnn_y;
  INFO("classical/pgnn y-MSE: magnitude_phase " << magnitude_ratio << "x, phase_current " << current_ratio << "x");
  CHECK(magnitude_ratio >= 5.0);
  CHECK(current_ratio >= 5.0);
  // Of the same order: within a factor 3 of each other.
  CHECK(current_ratio >= magnitude_ratio / 3.0);
  CHECK(current_ratio <= magnitude_ratio * 3.0);

  // magnitude_phase: the currents are reconstructed later, not in the data.
  CHECK_FALSE(magnitude.experiments.has("ia_A"));
  // phase_current: the sent currents are in the data, and they are the
  // drive's nominal law (18)/(19) at the measured position, computed here.
  REQUIRE(current.experiments.has("ia_A"));
  REQUIRE(current.experiments.has("ib_A"));
  const MotorDescription motor = load_motor_description(source("config/motor-sim-phase-current.yaml"));
  const auto magnitude_N = current.experiments.numbers("magnitude_N");
  const auto delta_rad = current.experiments.numbers("delta_rad");
  const auto y_m = current.experiments.numbers("y_m");
  const auto ia_A = current.experiments.numbers("ia_A");
  const auto ib_A = current.experiments.numbers("ib_A");
  REQUIRE(ia_A.size() > 1000);
  double largest_A = 0.0;
  for (std::size_t r = 0; r < ia_A.size(); ++r) {
    const Eigen::Vector2d i = drive_phase_currents(motor.drive, {magnitude_N[r], delta_rad[r]}, y_m[r],
                                                   motor.pole_pitch_m);
    REQUIRE(std::abs(ia_A[r] - i.x()) <= 1e-9 * (1.0 + std::abs(i.x())));
    REQUIRE(std::abs(ib_A[r] - i.y()) <= 1e-9 * (1.0 + std::abs(i.y())));
    largest_A = std::max(largest_A, std::abs(ia_A[r]));
  }
  CHECK(largest_A > 0.1);
}
