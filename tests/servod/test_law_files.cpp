// Laws the daemon refuses though their files are well formed: a model that
// costs more than the loop's budget, a calibration or model whose gains are no
// motor's (commutation/law_check.hpp), at start-up and on load commands.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "daemon/servod/axis_wiring.hpp"
#include "support/ideal_plant.hpp"
#include "support/temporary_directory.hpp"

using namespace clm;
using namespace clm::servod;

namespace {

/// config/servod.yaml (its encoder absolute) on the virtual clock, without
/// telemetry, loading from `directory` too.
ServodConfig virtual_config(const std::string& directory) {
  auto config = load_servod_config(clm::test::absolute_encoder_path());
  config.loop.clock = ClockMode::kVirtual;
  config.telemetry.enabled = false;
  config.commands.file_directories.push_back(std::filesystem::canonical(directory).string());
  return config;
}

/// config/motor-sim.yaml's truth as a PGNN with networks of the given hidden sizes (zero).
ModelFile sim_model(const std::vector<int>& hidden) {
  const std::vector<ClassicalCoilSet> coil_sets{
      {61.3, -0.54, 0.1, -0.08}, {61.6, -0.55, 0.1, 0.0}, {60.1, -0.55, 0.1, 0.08}};
  ModelFile file;
  file.model = make_classical_model(0.03, coil_sets, hidden, hidden);
  return file;
}

CalibrationFile sim_calibration(double second_motor_constant_N_per_A) {
  CalibrationFile file;
  file.pole_pitch_m = 0.03;
  file.drive = {67.0, -0.52};
  file.method = "algorithm1";
  for (const double k : {61.3, second_motor_constant_N_per_A, 60.1}) {
    CalibrationFile::CoilSet coil_set;
    coil_set.estimate = {k, -0.55};
    coil_set.delta_rad = {0.0, 1.5};
    coil_set.gain_ratio = {1.0, 0.1};
    file.coil_sets.push_back(coil_set);
  }
  return file;
}

servo::Command load(servo::CommandKind kind, const std::string& path) {
  servo::Command command;
  command.sequence = 5;
  command.kind = kind;
  command.path.assign(path);
  if (kind == servo::CommandKind::kLoadModel) command.commutation = servo::CommutationMode::kPgnn;
  return command;
}

}  // namespace

TEST_CASE("load_model and load_calibration refuse a law beyond the budget or with a coil set off nominal, naming "
          "the numbers and the file",
          "[servod][files][law_check]") {
  test::TemporaryDirectory directory("clm_law_files");
  const std::string costly = directory.file("costly.yaml");    // 4 × 64 hidden: 9 · 17 664 > 25 000
  const std::string zeroed = directory.file("zeroed.yaml");    // coil set 3 without gain
  const std::string good = directory.file("good.yaml");        // the paper's 2/16
  const std::string tiny_k = directory.file("tiny-k.yaml");    // k = 1e-300 on coil set 2
  const std::string good_k = directory.file("good-k.yaml");
  std::ofstream(costly) << format_model_file(sim_model({64, 64, 64, 64}));
  ModelFile without_gain = sim_model({2});
  without_gain.model.coil_sets[2].a_N_per_A.setZero();
  without_gain.model.coil_sets[2].b_N_per_A.setZero();
  std::ofstream(zeroed) << format_model_file(without_gain);
  std::ofstream(good) << format_model_file(sim_model({2}));
  std::ofstream(tiny_k) << format_calibration_file(sim_calibration(1e-300));
  std::ofstream(good_k) << format_calibration_file(sim_calibration(61.6));

  WiredAxis axis(virtual_config(directory.path()));
  ServoDaemon& daemon = axis.daemon;
  using servo::CommandKind;

  const CommandReply cost = daemon.submit(load(CommandKind::kLoadModel, costly));
  CHECK_FALSE(cost.accepted());
  CHECK(cost.text() == "rejected: load_model: costs 160132 multiply-adds per cycle, budget 25000 at 1000 Hz: '" +
                         costly + "'");

  const CommandReply gain = daemon.submit(load(CommandKind::kLoadModel, zeroed));
  CHECK_FALSE(gain.accepted());
  CHECK_THAT(gain.text(), Catch::StartsWith("rejected: load_model: coil set 3 at y = -0.12 m: motor constant 0 N/A "
                                          "outside [6.7, 670] N/A"));

  const CommandReply k = daemon.submit(load(CommandKind::kLoadCalibration, tiny_k));
  CHECK_FALSE(k.accepted());
  CHECK_THAT(k.text(), Catch::StartsWith("rejected: load_calibration: coil set 2: motor constant 1e-300 N/A"));

  CHECK(daemon.submit(load(CommandKind::kLoadModel, good)).accepted());
  CHECK(daemon.submit(load(CommandKind::kLoadCalibration, good_k)).accepted());
}

TEST_CASE("A configuration naming a law beyond the budget does not start, naming file, cost and budget",
          "[servod][files][law_check]") {
  test::TemporaryDirectory directory("clm_law_files");
  const std::string costly = directory.file("costly.yaml");
  std::ofstream(costly) << format_model_file(sim_model({64, 64, 64, 64}));
  ServodConfig config = virtual_config(directory.path());
  config.commutation.pgnn_model_file = costly;
  CHECK_THROWS_WITH(WiredAxis(config), costly + ": pgnn model: costs 160132 multiply-adds per cycle, budget 25000 at "
                                                "1000 Hz");

  config.commutation.pgnn_model_file.clear();
  const std::string tiny_k = directory.file("tiny-k.yaml");
  std::ofstream(tiny_k) << format_calibration_file(sim_calibration(1e-300));
  config.commutation.calibration_file = tiny_k;
  CHECK_THROWS_WITH(WiredAxis(config), Catch::StartsWith(tiny_k + ": calibration: coil set 2: motor constant 1e-300"));
}
