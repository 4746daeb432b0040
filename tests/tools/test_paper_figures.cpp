// The default motor reproduces the situation of the paper's Table 2
// (docs/simulator.md) on the daemon's servo cycle, as the in-process
// commissioning runs it (commission::InProcessRunner, virtual clock):
// Algorithm 1 on experiment-mode Fig. 8 data (each coil set alone,
// Δ = ∓π/4, closed loop without feedforward; forces paired with the
// previous cycle's setpoints by data::read_experiment_data), then the Fig. 8
// reference in closed loop with the original (uncalibrated) and the
// calibrated classical commutation and the oracle, each with its own
// identified feedforward as in the paper.
//
// The figures of docs/simulator.md come from
//   ./build/tests/commission_loop_tests "[paper]" -s        (default motor)
//   ./build/tests/commission_loop_tests "[paper_study]"     (other seeds)
#include <catch2/catch.hpp>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "config/atomic_file.hpp"
#include "daemon/servod/axis_wiring.hpp"
#include "daemon/servod/program_file.hpp"
#include "drivers/sim/motor_file.hpp"
#include "drivers/sim/sim_support.hpp"
#include "support/daemon_experiments.hpp"
#include "support/temporary_directory.hpp"
#include "tools/commission/commission.hpp"
#include "tools/commission/runs.hpp"
#include "tools/data/csv_table.hpp"
#include "tools/data/experiment_data.hpp"

using namespace clm;
using servo::CommutationMode;

namespace {

using sim::fixtures::source_path;

struct CommutationFigures {
  control::DirectionMse mse;
  double tracking_mse_m2 = 0.0;
};

struct PaperFigures {
  CalibrationFile algorithm1;
  CalibrationFile offset_robust;
  CommutationFigures original;
  CommutationFigures classical;
  CommutationFigures oracle;
};

/// The configuration `servod_file` on a simulated motor of `parameters`, on
/// the daemon's cycle, with the Fig. 8 program fitted to its soft limits.
/// Files (the calibration) go to a temporary directory the daemon may load from.
class PaperRuns {
 public:
  PaperRuns(const std::string& servod_file, const sim::MotorParameters& parameters)
      : directory_("clm-paper-figures"), config_(config(servod_file, directory_)),
        runner_(config_, servod::wire_simulated_axis(config_, parameters)) {
    bool scaled = false;
    program_ = servod::fit_program(servod::load_program_file(source_path("config/programs/fig8.yaml")),
                                   config_.servo.soft_limit_min_m, config_.servo.soft_limit_max_m, scaled);
    runner_.enable();
  }

  // Algorithm 1 (and its offset-robust variant) on experiment-mode data:
  // each coil set alone, Δ = ∓π/4 (ζ̂_i = ζ̂ + (−1)^i Δ), no feedforward.
  void calibrate(PaperFigures& figures) {
    test::DaemonExperiments experiments;
    experiments.motor = config_.motor;
    for (int l = 1; l <= config_.motor.coil_sets; ++l) {
      for (const double delta_rad : {-kPi / 4.0, kPi / 4.0}) {
        runner_.set_experiment(l, delta_rad);
        experiments.runs.push_back(runner_.run_program(program_, "", "experiment coil set " + std::to_string(l),
                                                             commission::Disturbance::kRunsOn));
      }
    }
    const test::ExperimentColumns columns = test::experiment_columns(experiments);
    data::ExperimentData data = data::read_experiment_data(
        data::CsvTable::from_columns("paper experiments", columns.names, columns.values), config_.motor);
    data.reference = servod::encoder_reference(config_);  // the frame the axis homed to
    figures.algorithm1 = data::calibrate_motor(data, config_.motor, data::CalibrationMethod::kAlgorithm1);
    figures.offset_robust = data::calibrate_motor(data, config_.motor, data::CalibrationMethod::kOffsetRobust);
  }

  // Closed loop as in the paper's comparison: a first run without
  // feedforward identifies m, f_v, f_c for this commutation
  // (docs/commutation.md §10), the second run with that feedforward is measured.
  CommutationFigures measure(CommutationMode mode) {
    runner_.set_commutation(mode);
    runner_.load_feedforward({}, "");
    const commission::Recording identification = runner_.run_program(program_, "", "feedforward data", commission::Disturbance::kRestarts);
    runner_.load_feedforward(commission::identify_ff(identification), "");
    const commission::Recording evaluation = runner_.run_program(program_, "", "evaluation", commission::Disturbance::kRestarts);
    const commission::CommutationResult result = commission::evaluate(evaluation, config_.servo.period_s);
    return {result.mse, result.tracking_mse_m2};
  }

  void load_calibration(const CalibrationFile& file) {
    const std::string path = directory_.file("calibration.yaml");
    write_file_atomically(path, format_calibration_file(file));
    runner_.load_calibration(path);
  }

 private:
  static servod::ServodConfig config(const std::string& servod_file, const test::TemporaryDirectory& directory) {
    servod::ServodConfig config = servod::load_servod_config(source_path(servod_file));
    config.commands.file_directories.push_back(std::filesystem::canonical(directory.path()).string());
    return config;
  }

  test::TemporaryDirectory directory_;
  servod::ServodConfig config_;
  commission::InProcessRunner runner_;
  servod::ProgramFile program_;
};

PaperFigures evaluate(const std::string& servod_file, const sim::MotorParameters& parameters) {
  PaperRuns runs(servod_file, parameters);
  PaperFigures figures;
  runs.calibrate(figures);
  figures.original = runs.measure(CommutationMode::kOriginal);
  runs.load_calibration(figures.algorithm1);
  figures.classical = runs.measure(CommutationMode::kClassical);
  figures.oracle = runs.measure(CommutationMode::kOracle);
  return figures;
}

void print_estimates(const sim::MotorParameters& parameters, const PaperFigures& figures) {
  for (std::size_t l = 0; l < figures.algorithm1.coil_sets.size(); ++l) {
    const auto& truth = parameters.electromagnetics.coil_sets[l];
    const auto& paper = figures.algorithm1.coil_sets[l].estimate;
    const auto& robust = figures.offset_robust.coil_sets[l].estimate;
    std::printf("  coil set %zu: true k %.2f N/A, zeta %.3f rad; Algorithm 1 k %.2f N/A, zeta %.3f rad; "
                "offset-robust k %.2f N/A, zeta %.3f rad\n",
                l + 1, truth.motor_constant_N_per_A, truth.phase_offset_rad, paper.motor_constant_N_per_A,
                paper.phase_offset_rad, robust.motor_constant_N_per_A, robust.phase_offset_rad);
  }
}

void print(const char* name, const CommutationFigures& f) {
  std::printf("  %-9s filtered (unfiltered) MSE: y %6.2f (%6.2f) N², x %.3f (%.3f) N², z %.3f (%.3f) N²m²; "
              "tracking %.3g m²\n",
              name, f.mse.filtered[0], f.mse.unfiltered[0], f.mse.filtered[1], f.mse.unfiltered[1], f.mse.filtered[2],
              f.mse.unfiltered[2], f.tracking_mse_m2);
}

void print(const sim::MotorParameters& parameters, const PaperFigures& figures) {
  print_estimates(parameters, figures);
  print("original", figures.original);
  print("classical", figures.classical);
  print("oracle", figures.oracle);
}

}  // namespace

TEST_CASE("default motor: calibrated classical y-MSE within 15..40 N² and below the original's", "[sim][paper]") {
  const sim::MotorParameters parameters = sim::load_motor_parameters(source_path("config/motor-sim.yaml"));
  const PaperFigures figures = evaluate("config/servod.yaml", parameters);
  std::printf("default motor (config/motor-sim.yaml) on the daemon's cycle (config/servod.yaml), Fig. 8 reference:\n");
  print(parameters, figures);

  CHECK(figures.classical.mse.filtered[0] >= 15.0);
  CHECK(figures.classical.mse.filtered[0] <= 40.0);
  CHECK(figures.original.mse.filtered[0] > figures.classical.mse.filtered[0]);
  // No static model does better than the oracle, and it leaves about the
  // direction-dependent term C_y² (the translator moves most of the time).
  const double c = parameters.electromagnetics.direction_dependent_N_N_Nm.x();
  CHECK(figures.oracle.mse.filtered[0] < figures.classical.mse.filtered[0]);
  CHECK(figures.oracle.mse.filtered[0] < 1.5 * c * c);
}

TEST_CASE("default motor figures for other truth and noise seeds", "[.][paper_study]") {
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    sim::MotorParameters parameters = sim::load_motor_parameters(source_path("config/motor-sim.yaml"));
    parameters.electromagnetics.seed = seed;
    parameters.sensors.noise_seed = 100 + seed;
    std::printf("truth seed %llu, noise seed %llu:\n", static_cast<unsigned long long>(seed),
                static_cast<unsigned long long>(100 + seed));
    print(parameters, evaluate("config/servod.yaml", parameters));
  }
  // What biases Algorithm 1: the default motor with the direction-dependent
  // force and/or the cogging switched off.
  for (int variant = 0; variant < 4; ++variant) {
    sim::MotorParameters parameters = sim::load_motor_parameters(source_path("config/motor-sim.yaml"));
    auto& em = parameters.electromagnetics;
    if ((variant & 1) != 0) em.direction_dependent_N_N_Nm.setZero();
    if ((variant & 2) != 0) {
      em.cogging_periodic.clear();
      em.cogging_slow_rms_N_N_Nm.setZero();
      em.cogging_spring_rate_N_N_Nm_per_m.setZero();
    }
    std::printf("default motor%s%s:\n", (variant & 1) != 0 ? " without the direction-dependent force" : "",
                (variant & 2) != 0 ? " without cogging" : "");
    PaperRuns runs("config/servod.yaml", parameters);
    PaperFigures figures;
    runs.calibrate(figures);
    print_estimates(parameters, figures);
  }
  const sim::MotorParameters two_coil = sim::load_motor_parameters(source_path("config/motor-sim-2coil.yaml"));
  std::printf("two-coil motor (config/servod-2coil.yaml), Fig. 8 reference scaled to its soft limits:\n");
  print(two_coil, evaluate("config/servod-2coil.yaml", two_coil));
}
