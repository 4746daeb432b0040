// The whole commissioning on simulated motors: the targets of the tools and
// commissioning issues, measured against the simulator (label slow).
//
//   ctest --test-dir build -L slow        or   build/tests/commissioning_tests -s
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "daemon/control/metrics.hpp"
#include "drivers/sim/motor_file.hpp"
#include "tools/data/csv_table.hpp"
#include "support/temporary_directory.hpp"
#include "tools/commission/commission.hpp"
#include "tools/commission/runs.hpp"
#include "daemon/servod/feedforward_file.hpp"
#include "daemon/servod/program_file.hpp"

using namespace clm;

namespace {

std::string source(const std::string& relative) { return std::string(CLM_SOURCE_DIR) + "/" + relative; }

const commission::CommutationResult& find(const std::vector<commission::CommutationResult>& results,
                                          const std::string& name) {
  for (const auto& r : results) {
    if (r.name == name) return r;
  }
  FAIL("no result for " << name);
  throw std::logic_error("unreachable");
}

// `payload_kg` > 0: also from positions (--no-force-sensor), the mass from
// the experiments with that payload (--payload-kg): the shipped
// configurations' control.mass_kg is a few per cent off the simulator's, as
// a CAD model's would be, and is not the scale.
commission::Report run_commission(const test::TemporaryDirectory& directory, const std::string& config,
                                  double payload_kg = 0.0) {
  commission::Options options;
  options.config_path = source(config);
  options.out_dir = directory.file("commission");
  options.no_force_sensor = payload_kg > 0.0;
  options.payload_kg = payload_kg;
  options.mass_from_config = payload_kg == 0.0;
  return commission::run(options);
}

void check_ratios(const commission::Report& report, const std::vector<commission::CommutationResult>& results,
                  double y_ratio, double tracking_ratio, const std::string& pgnn_name = "pgnn") {
  const auto& classical = find(results, "classical");
  const auto& pgnn = find(results, pgnn_name);
  const auto& spline = find(results, "spline");
  REQUIRE(classical.evaluated);
  REQUIRE(pgnn.evaluated);
  REQUIRE(spline.evaluated);
  INFO("classical y/x/z " << classical.mse.filtered[0] << " " << classical.mse.filtered[1] << " "
                          << classical.mse.filtered[2] << " tracking " << classical.tracking_mse_m2);
  INFO("pgnn y/x/z " << pgnn.mse.filtered[0] << " " << pgnn.mse.filtered[1] << " " << pgnn.mse.filtered[2]
                     << " tracking " << pgnn.tracking_mse_m2);
  INFO("spline y/x/z " << spline.mse.filtered[0] << " " << spline.mse.filtered[1] << " " << spline.mse.filtered[2]
                       << " tracking " << spline.tracking_mse_m2);
  // Tracking: what the commutation adds to the oracle's tracking MSE (every
  // law meets the same run, disturbance included, and the oracle commutes
  // exactly: the error budget's commutation part). The paper's ratio is of
  // the whole MSE on a machine whose floor lies far below the commutation's
  // error; with the plant's disturbance floor the whole MSE of every law is
  // within about 1.1x of the oracle's and only the excess still measures
  // the commutation.
  const auto& oracle = find(results, "oracle");
  REQUIRE(oracle.evaluated);
  const auto excess = [&](const commission::CommutationResult& r) { return r.tracking_mse_m2 - oracle.tracking_mse_m2; };
  INFO("oracle tracking " << oracle.tracking_mse_m2);
  for (const auto* model : {&pgnn, &spline}) {
    CHECK(classical.mse.filtered[0] >= y_ratio * model->mse.filtered[0]);
    CHECK(classical.mse.filtered[1] >= 2.0 * model->mse.filtered[1]);
    CHECK(classical.mse.filtered[2] >= 2.0 * model->mse.filtered[2]);
    CHECK(excess(classical) >= tracking_ratio * excess(*model));
  }
  (void)report;
}

// The force every law's setpoints make reaches the translator through the
// simulated drive's setpoint delay τ_s and its current loop (first order at
// ω_c for a step held over a period), so over a period it lags F* by about
// τ = τ_s + 1/ω_c and even the oracle's true y error is about τ·dF*/dt: on
// the oracle's evaluation run, F* − τ·ΔF*/T against F*, filtered as the
// true error is. 0 on an ideal drive.
double drive_lag_floor_N2(const std::string& commission_dir, const sim::MotorParameters& truth) {
  const auto& drive = truth.drive;
  const double lag_s = drive.setpoint_delay_s +
                       (drive.current_loop.ideal() ? 0.0 : 1.0 / (kTwoPi * drive.current_loop.bandwidth_Hz));
  const auto table = data::CsvTable::load(commission_dir + "/evaluation-oracle.csv");
  const auto time = table.numbers("t_s");
  const auto demand = table.numbers("Fy_star_N");
  REQUIRE(time.size() > 2);
  const double period_s = time[1] - time[0];
  std::vector<Eigen::Vector3d> lagged, desired;
  for (std::size_t k = 0; k < demand.size(); ++k) {
    const double rate = k == 0 ? 0.0 : (demand[k] - demand[k - 1]) / period_s;
    lagged.emplace_back(demand[k] - lag_s * rate, 0.0, 0.0);
    desired.emplace_back(demand[k], 0.0, 0.0);
  }
  return control::commutation_error_mse(lagged, desired, period_s).filtered[0];
}

// The nuisance terms and the truth: the simulator's own bias and
// direction-dependent force, and its electromagnetic truth, are the
// independent expectations (docs/commutation.md, "Nuisance terms").
void check_against_truth(const commission::Report& report, const std::string& motor_file, double true_y_mse_N2,
                         const std::string& commission_dir) {
  const sim::MotorParameters truth = sim::load_motor_parameters(source(motor_file));
  const double bias_N = truth.sensors.force_bias_N_N_Nm[0];
  const Wrench direction = truth.electromagnetics.direction_dependent_N_N_Nm;
  for (const auto* selection : {&report.pgnn_selection, &report.spline_selection}) {
    REQUIRE(selection->nuisance);
    CHECK(selection->sensor_offset.offset_N == Approx(bias_N).margin(0.05));
    CHECK(selection->sensor_offset.mass_kg == Approx(truth.mechanics.translator_mass_kg).epsilon(0.05));
  }
  // The spline kept finds C within 20 % in y, the direction the experiments excite most
  // (on 2026-11-25: 7 % on the default and the 4-coil motor, 16 % on the 2-coil
  // motor, whose shorter stroke scales the program down).
  const auto& spline = report.spline_selection.trials[report.spline_selection.chosen];
  for (const auto& entry : spline.coil_sets) {
    CHECK(entry.report.direction_force.amplitude[0] == Approx(direction[0]).epsilon(0.2));
  }
  // Every model put to use satisfies Proposition 4.1 with its nuisance terms.
  for (const auto* entries : {&report.pgnn, &report.spline}) {
    for (const auto& entry : *entries) {
      for (bool holds : entry.report.proposition_holds) CHECK(holds);
    }
  }
  // The recommendation follows its rule (docs/commutation.md, "The
  // recommendation"): a clear win by at least k standard errors of the
  // paired difference, or a tie given to the first tied law in kTieOrder.
  const data::Verdict& verdict = report.verdict;
  if (report.decided_by != "no force sensor") {
    CHECK(report.recommended == data::choose_law(report.law_scores).recommended);
    CHECK(report.decided_by == (verdict.tie ? "tie rule" : "validation score"));
    if (!verdict.tie && !verdict.runner_up.empty()) CHECK(verdict.margin_standard_errors >= data::kTieStandardErrors);
  }
  // Every score comes with a standard error from the held-out blocks.
  for (const auto& law : report.law_scores) {
    INFO(law.law << " " << law.score.value << " ± " << law.score.standard_error);
    CHECK(std::isfinite(law.score.standard_error));
  }
  // The law recommended commands the electromagnetic force it is asked for.
  REQUIRE((report.recommended == "pgnn" || report.recommended == "spline" || report.recommended == "spline-position"));
  const auto& recommended = find(report.results, report.recommended);
  const auto& oracle = find(report.results, "oracle");
  REQUIRE(recommended.truth_known);
  INFO("recommended " << report.recommended << ": true y-MSE " << recommended.true_mse.filtered[0]
                      << " N², tracking " << recommended.tracking_mse_m2 / oracle.tracking_mse_m2 << "x the oracle's");
  // Every law meets the same drive, whose lag the oracle's true error
  // measures (below): the bound is on what a law adds to it.
  CHECK(recommended.true_mse.filtered[0] - oracle.true_mse.filtered[0] <= true_y_mse_N2);
  // Its static error (the law alone on the static truth) within the same bound.
  INFO("recommended static y-MSE " << recommended.static_mse.filtered[0] << " N²");
  CHECK(recommended.static_mse.filtered[0] <= true_y_mse_N2);
  // The PGNN kept, too (with the field harmonics in its physics part when
  // the validation chose them; docs/commutation.md).
  const auto& pgnn = find(report.results, "pgnn");
  INFO("pgnn (" << report.pgnn_selection.trials[report.pgnn_selection.chosen].capacity << "): true y-MSE "
                << pgnn.true_mse.filtered[0] << " N², tracking " << pgnn.tracking_mse_m2 / oracle.tracking_mse_m2
                << "x the oracle's");
  CHECK(pgnn.true_mse.filtered[0] - oracle.true_mse.filtered[0] <= true_y_mse_N2);
  CHECK(pgnn.tracking_mse_m2 <= 5.0 * oracle.tracking_mse_m2);
  // The oracle is exact on the true error, up to the motion within a period
  // (1e-3 N² on an ideal drive) and the drive's lag (the first-order floor,
  // within half of it: the loop's step is not exactly first order over a
  // period, and the delay moves part of a step into the next period).
  const double floor_N2 = drive_lag_floor_N2(commission_dir, truth);
  INFO("oracle true y " << oracle.true_mse.filtered[0] << " N², the drive's lag floor " << floor_N2 << " N²");
  CHECK(oracle.true_mse.filtered[0] < 1.5 * floor_N2 + 1e-3);
  // Its static error is zero up to rounding: the exact inverse of the same
  // static truth at the same position, through an ideal drive (forces of
  // about 10² N, so 10⁻⁶ N² is a millionth of a newton's square).
  INFO("oracle static y " << oracle.static_mse.filtered[0] << " N²");
  CHECK(oracle.static_mse.filtered[0] < 1e-6);
  CHECK(oracle.tracking_mse_m2 < recommended.tracking_mse_m2);
}

// Commissioning from positions (--no-force-sensor) against the force-sensor
// laws of the same run and the simulator's mechanics and coil sets: the
// targets of the position-based identification (docs/commutation.md,
// "Without a force sensor").
void check_from_position(const commission::Report& report, const std::string& motor_file) {
  const sim::MotorParameters truth = sim::load_motor_parameters(source(motor_file));
  REQUIRE(report.from_position);
  const auto& position = find(report.results, "spline-position");
  const auto& classical = find(report.results, "classical");
  // Against the law the force sensor's models alone would give.
  REQUIRE((report.force_recommended == "pgnn" || report.force_recommended == "spline"));
  const auto& recommended = find(report.results, report.force_recommended);
  REQUIRE(position.evaluated);
  REQUIRE(position.truth_known);
  INFO("spline-position tracking " << position.tracking_mse_m2 << ", true y " << position.true_mse.filtered[0]
                                   << "; " << report.force_recommended << " tracking " << recommended.tracking_mse_m2
                                   << ", true y " << recommended.true_mse.filtered[0] << "; classical tracking "
                                   << classical.tracking_mse_m2);
  CHECK(position.tracking_mse_m2 <= 2.0 * recommended.tracking_mse_m2);
  const auto& oracle = find(report.results, "oracle");
  CHECK(classical.tracking_mse_m2 - oracle.tracking_mse_m2 >= 4.0 * (position.tracking_mse_m2 - oracle.tracking_mse_m2));
  CHECK(position.true_mse.filtered[0] <= 2.0 * recommended.true_mse.filtered[0]);
  // The force scale from the payload within 1 % of the simulator's mass (the target).
  INFO("mass " << report.position.mass_kg << " kg from " << report.position_mass_source);
  CHECK(report.position.mass_kg == Approx(truth.mechanics.translator_mass_kg).epsilon(0.01));
  // The mechanics: viscous friction, and Coulomb friction with the
  // direction-dependent force (one term from motion; the simulator's sign:
  // its C adds C·tanh, friction subtracts F_c·tanh).
  const double direction_N = truth.mechanics.coulomb_friction_N - truth.electromagnetics.direction_dependent_N_N_Nm[0];
  for (const auto& fit : report.position.fits) {
    CHECK(fit.viscous_N_s_per_m == Approx(truth.mechanics.viscous_friction_N_s_per_m).epsilon(0.05));
    CHECK(fit.direction_N == Approx(direction_N).epsilon(0.05));
  }
  // Algorithm 1 on the reconstructed force finds every coil set's k and ζ.
  REQUIRE(report.calibration_position.coil_sets.size() == truth.electromagnetics.coil_sets.size());
  for (std::size_t l = 0; l < truth.electromagnetics.coil_sets.size(); ++l) {
    const auto& estimate = report.calibration_position.coil_sets[l].estimate;
    const auto& coil_set = truth.electromagnetics.coil_sets[l];
    CHECK(estimate.motor_constant_N_per_A == Approx(coil_set.motor_constant_N_per_A).epsilon(0.05));
    CHECK(estimate.phase_offset_rad == Approx(coil_set.phase_offset_rad).margin(0.03));
  }
}

// A model beyond its data (docs/design-decisions.md, "A model's law outside
// its data"): the commissioned PGNN, identified on ±0.10 m, drives moves to
// the ends of the soft limits (±0.11 m on the default motor) without a
// fault, and its following error beyond its data is within 2× of calibrated
// classical commutation's on the same moves (issue target). Each law with
// its own commissioned feedforward, the disturbance restarted for both.
void check_soft_limit_ends(const std::string& config_file, const std::string& dir) {
  servod::ServodConfig config = servod::load_servod_config(source(config_file));
  config.loop.clock = servod::ClockMode::kVirtual;
  config.telemetry.enabled = false;
  config.commands.file_directories.push_back(std::filesystem::canonical(dir).string());  // as clm commission does
  const double data_max_m = 0.10;  // programs/identification.yaml's extent
  const double end_max_m = config.servo.soft_limit_max_m - 1e-3, end_min_m = config.servo.soft_limit_min_m + 1e-3;
  const std::string program_path = dir + "/soft-limit-ends.yaml";
  {
    std::ofstream out(program_path);
    out << "format: clm-servo-program\nformat_version: 1\ndescription: \"to the soft limits and back\"\n"
        << "start_m: 0.0\nsteps:\n";
    for (const double target : {end_max_m, end_min_m, 0.0}) {
      out << "  - {target_m: " << target
          << ", velocity_m_per_s: 0.1, acceleration_m_per_s2: 1.0, jerk_m_per_s3: 500.0, dwell_s: 0.2}\n";
    }
  }
  const servod::ProgramFile program = servod::load_program_file(program_path);
  double beyond_error_m[2] = {0.0, 0.0};
  int k = 0;
  for (const auto& [law, mode] : {std::pair{"classical", servo::CommutationMode::kClassical},
                                  std::pair{"pgnn", servo::CommutationMode::kPgnn}}) {
    commission::InProcessRunner runner(config);
    runner.load_calibration(dir + "/calibration.yaml");
    if (mode == servo::CommutationMode::kPgnn) runner.load_model(mode, dir + "/model-pgnn.yaml");
    const std::string feedforward = dir + "/feedforward-" + law + ".yaml";
    runner.load_feedforward(servod::load_feedforward_file(feedforward).parameters, feedforward);
    runner.enable();  // homed first where the encoder is incremental, as the laws need
    runner.set_commutation(mode);
    const commission::Recording run =
        runner.run_program(program, program_path, std::string("soft-limit ends, ") + law, commission::Disturbance::kRestarts);
    REQUIRE_FALSE(run.samples.empty());
    std::size_t beyond = 0;
    for (const auto& sample : run.samples) {
      INFO(law << " at cycle " << sample.cycle << ": " << servo::describe(sample.fault));
      REQUIRE(sample.fault == servo::Fault::kNone);
      if (std::abs(sample.r_m) > data_max_m) {
        beyond_error_m[k] = std::max(beyond_error_m[k], std::abs(sample.r_m - sample.y_m));
        ++beyond;
      }
    }
    REQUIRE(beyond > 100);  // the moves spend time beyond the data
    ++k;
  }
  INFO("largest following error beyond ±" << data_max_m << " m: classical " << beyond_error_m[0] << " m, pgnn "
                                         << beyond_error_m[1] << " m");
  CHECK(beyond_error_m[1] <= 2.0 * beyond_error_m[0]);
}

}  // namespace

TEST_CASE("commissioning the default motor meets the paper's improvements on Fig. 8 and on a held-out trajectory",
          "[commission][slow]") {
  const test::TemporaryDirectory directory("clm-commission-default");
  const auto report = run_commission(directory, "config/servod.yaml", 5.0);
  // Independent expectations: the issues' targets and the simulator's truth
  // (oracle). Every bound below is a target set before the code was written
  // (PGNN commutation 10x and tracking 4x better than calibrated classical,
  // the paper's Table 2; true y-MSE 0.05 N² and PGNN tracking within 5x the
  // oracle's), or a property of the simulated motor (classical y-MSE
  // 15..40 N²: its field harmonics and cogging are sized so), never one
  // machine's result: identification gives the same bits on every x86-64 CPU
  // (docs/commutation.md, "Reproducibility"), and the figures it gives are in
  // docs/commutation.md, "Before and after".
  const auto& original = find(report.results, "original");
  const auto& classical = find(report.results, "classical");
  CHECK(classical.mse.filtered[0] >= 15.0);
  CHECK(classical.mse.filtered[0] <= 40.0);
  CHECK(original.mse.filtered[0] > classical.mse.filtered[0]);
  check_ratios(report, report.results, 10.0, 4.0);
  // Held out: the same targets on a trajectory used for no fit.
  REQUIRE(report.validation.size() == 8);  // six laws, and two from positions
  check_ratios(report, report.validation, 10.0, 4.0);
  check_ratios(report, report.results, 10.0, 4.0, "pgnn-paper");  // the paper's 2/16 PGNN too
  check_against_truth(report, "config/motor-sim.yaml", 0.05, directory.file("commission"));
  check_from_position(report, "config/motor-sim.yaml");
  check_soft_limit_ends("config/servod.yaml", directory.file("commission"));
  // The error budget: for the recommended law its parts, each from runs of
  // their own, add up to its tracking MSE within 10 % (the realistic plant's
  // target; uncorrelated sources through a linear loop add in MSE), and the
  // disturbance floor the shipped motor carries is a part of it. The
  // oracle's commutation part is zero, but its loop and sources come from
  // three other runs, so its parts too must add up within the same 10 %.
  INFO(commission::error_budget_summary(report));
  REQUIRE(report.budget.computed);
  CHECK(report.budget.disturbance_m2 > 0.0);
  CHECK(report.budget.loop_m2 > 0.0);
  for (const std::string& law : {report.recommended, std::string("oracle")}) {
    const std::optional<commission::LawBudget> budget = commission::law_budget(report, law);
    REQUIRE(budget);
    INFO(law << ": the parts " << budget->sum_m2 << " m², the whole " << budget->whole_m2 << " m²");
    CHECK(std::abs(budget->whole_m2 - budget->sum_m2) <= 0.1 * budget->whole_m2);
  }
  // The live split (no truth) against the simulator's (1 − the oracle's
  // tracking MSE over the law's, every law meeting the same run): calibrated
  // classical commutation, whose error is nearly all its tracking error
  // (oracle split 0.99), is found commutation-made for the most part; the
  // oracle, which commutes exactly, is found so for a small part only (what
  // of the loop's own following error resembles a force of position).
  const auto live_share = [](const commission::CommutationResult& r) {
    return r.tracking_split.commutation_m2 / r.tracking_split.total_m2;
  };
  const auto& oracle = find(report.results, "oracle");
  INFO("live split: classical " << live_share(classical) << " (oracle split "
                                << 1.0 - oracle.tracking_mse_m2 / classical.tracking_mse_m2 << "), oracle "
                                << live_share(oracle));
  CHECK(classical.tracking_split.total_m2 == Approx(classical.tracking_mse_m2).epsilon(1e-9));
  // The live split sees what is a force of position through the rigid loop
  // it models (no mode, no current loop, no delays): it must find at least
  // half of what the simulator says calibrated classical commutation adds,
  // and give the exact oracle little.
  CHECK(live_share(classical) >= 0.5 * (1.0 - oracle.tracking_mse_m2 / classical.tracking_mse_m2));
  CHECK(live_share(oracle) <= 0.3);
  // Proposition 4.1 on every coil set. (Wall time is a benchmark figure,
  // docs/benchmarks.md, not asserted here.)
  for (const auto& entry : report.pgnn) {
    for (bool holds : entry.report.proposition_holds) CHECK(holds);
  }
}

TEST_CASE("commissioning a second motor (two coil sets, 24 mm pole pitch) generalises", "[commission][slow]") {
  const test::TemporaryDirectory directory("clm-commission-2coil");
  const auto report = run_commission(directory, "config/servod-2coil.yaml", 2.5);
  REQUIRE(report.coil_sets == 2);
  // The targets (10x commutation, 4x tracking) are asserted on the
  // default motor above. Here the tracking ratio is held to 3x: on this motor
  // PGNN models of nearly equal cost (26) from the two solvers of
  // identification track 3.7x to 4.8x better than classical, so the tracking
  // ratio depends on which local optimum a solver finds, not only on how
  // well (docs/benchmarks.md, "Identification against PyTorch"). Which one
  // the default solver finds no longer depends on the machine
  // (docs/commutation.md, "Reproducibility").
  check_ratios(report, report.results, 10.0, 3.0);
  check_ratios(report, report.validation, 10.0, 3.0);
  check_against_truth(report, "config/motor-sim-2coil.yaml", 0.05, directory.file("commission"));
  check_from_position(report, "config/motor-sim-2coil.yaml");
}

TEST_CASE("commissioning a third motor (four coil sets, 40 mm pole pitch, 25 kg) generalises", "[commission][slow]") {
  const test::TemporaryDirectory directory("clm-commission-4coil");
  const auto report = run_commission(directory, "config/servod-4coil.yaml");
  REQUIRE(report.coil_sets == 4);
  check_ratios(report, report.results, 10.0, 4.0);
  check_against_truth(report, "config/motor-sim-4coil.yaml", 0.05, directory.file("commission"));
}

TEST_CASE("an axis without a force sensor is commissioned from positions alone, its mass from a known payload",
          "[commission][slow]") {
  const test::TemporaryDirectory directory("clm-commission-no-sensor");
  // config/servod.yaml without can.force_sensor_node_id, its motor file by
  // absolute path, and the mass the loop is tuned for 5 % above the
  // simulator's, as a user's CAD would give it.
  const double true_mass_kg = sim::load_motor_parameters(source("config/motor-sim.yaml")).mechanics.translator_mass_kg;
  std::ifstream in(source("config/servod.yaml"));
  std::ostringstream config;
  bool mass_set = false;
  for (std::string line; std::getline(in, line);) {
    if (line.find("force_sensor_node_id:") != std::string::npos) continue;
    if (line.rfind("motor_file:", 0) == 0) line = "motor_file: " + source("config/motor-sim.yaml");
    if (line.rfind("  mass_kg:", 0) == 0) {
      line = "  mass_kg: " + std::to_string(1.05 * true_mass_kg);
      mass_set = true;
    }
    config << line << "\n";
  }
  REQUIRE(mass_set);
  const std::string config_path = directory.file("servod-no-sensor.yaml");
  std::ofstream(config_path) << config.str();

  commission::Options options;
  options.config_path = config_path;
  options.out_dir = directory.file("commission");
  options.program_path = source("config/programs/fig8.yaml");
  options.experiment_program_path = source("config/programs/identification.yaml");
  options.validation_program_path = "none";
  CHECK_THROWS_WITH(commission::run(options), Catch::Contains("--no-force-sensor"));
  options.no_force_sensor = true;
  options.payload_kg = 5.0;
  options.mass_from_config = false;
  const commission::Report report = commission::run(options);
  // The payload experiments give the mass within 1 % (issue target), not the configuration's.
  INFO("mass " << report.position.mass_kg << " kg (" << report.position_mass_source << ", ratio "
               << report.payload_ratio << ") of " << true_mass_kg << " kg");
  CHECK(report.position.mass_kg == Approx(true_mass_kg).epsilon(0.01));
  CHECK(report.payload_ratio == Approx((true_mass_kg + 5.0) / true_mass_kg).epsilon(0.003));
  CHECK(std::filesystem::exists(options.out_dir + "/experiments-payload.csv"));

  std::vector<std::string> names;
  for (const auto& r : report.results) names.push_back(r.name);
  CHECK(names == std::vector<std::string>{"original", "classical-position", "spline-position", "oracle"});
  CHECK(report.recommended == "spline-position");
  // Nothing measured a force: no force-sensor data, models or error figures.
  CHECK_FALSE(std::filesystem::exists(options.out_dir + "/experiments.csv"));
  CHECK_FALSE(std::filesystem::exists(options.out_dir + "/model-pgnn.yaml"));
  CHECK(std::filesystem::exists(options.out_dir + "/model-spline-position.yaml"));
  const auto& original = find(report.results, "original");
  const auto& classical = find(report.results, "classical-position");
  const auto& position = find(report.results, "spline-position");
  CHECK(std::isnan(position.mse.filtered[0]));
  // The simulator's truth: the law commands the force it is asked for, and
  // tracks far better than the classical laws.
  REQUIRE(position.truth_known);
  INFO("true y " << position.true_mse.filtered[0] << " N², tracking " << position.tracking_mse_m2 << " m² against "
                 << classical.tracking_mse_m2 << " (classical-position), " << original.tracking_mse_m2 << " (original)");
  // Against the oracle of the same run, as in check_against_truth.
  const auto& oracle = find(report.results, "oracle");
  const auto excess = [&](const commission::CommutationResult& r) { return r.tracking_mse_m2 - oracle.tracking_mse_m2; };
  CHECK(position.true_mse.filtered[0] - oracle.true_mse.filtered[0] <= 0.01);
  CHECK(excess(classical) >= 4.0 * excess(position));
  CHECK(excess(original) >= 4.0 * excess(position));
}
