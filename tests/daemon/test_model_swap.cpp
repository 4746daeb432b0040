// Loading a commutation model while a program runs: the running law stays
// until the program has ended and the axis is at standstill, then the new one
// is in use; a file that does not load leaves the running law alone and the
// reply says why. Which law the cycle used is found from the bus: the
// setpoint frames of every cycle, decoded, against what each law computes
// here (its own instance, from the same file) for the cycle's position and
// force demand.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "commutation/commutator.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "drivers/sim/motor.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::CommutationMode;

namespace {

enum class Used { kFirst, kSecond, kNoSetpoints };

/// Two laws as the daemon would build them from their files.
class LawPair {
 public:
  LawPair(const servod::ServodConfig& config, const std::string& first_path, const std::string& second_path)
      : first_model_(load_model_file(first_path)),
        second_model_(load_model_file(second_path)),
        first_(first_model_.model, config.motor.drive, config.commutation.options),
        second_(second_model_.model, config.motor.drive, config.commutation.options) {
    first_out_.currents_A.resize(2 * config.motor.coil_sets);
    second_out_.currents_A.resize(2 * config.motor.coil_sets);
  }

  /// Which law produced the setpoints the daemon sent in its last cycle.
  /// Fails the test if neither does, or if the two laws cannot be told apart
  /// while current flows.
  Used used(servod::WiredAxis& axis) {
    servod::ServoDaemon& daemon = axis.daemon;
    const auto sent = test::sent_setpoints(axis);
    REQUIRE(sent.complete);
    if (!sent.command.enable) return Used::kNoSetpoints;
    const auto& record = daemon.cycle().record();
    const Wrench desired(record.Fy_star_N, record.Fx_star_N, record.Tz_star_Nm);
    first_.commutate(record.y_m, desired, first_out_);
    second_.commutate(record.y_m, desired, second_out_);
    const bool first = matches(sent.command, first_out_);
    const bool second = matches(sent.command, second_out_);
    INFO("cycle " << record.cycle << " force demand " << record.F_star_N << " N");
    REQUIRE(first != second);
    return first ? Used::kFirst : Used::kSecond;
  }

 private:
  // Encoding rounds to the nearest LSB: within half an LSB of the law's value.
  static bool matches(const can::SetpointCommand& sent, const CommutationOutput& law) {
    for (int l = 0; l < sent.coil_sets; ++l) {
      const auto s = static_cast<std::size_t>(l);
      if (std::abs(sent.setpoints[s].magnitude_N - law.setpoints[s].magnitude_N) > 0.5 * can::kMagnitudeLsb_N + 1e-9) return false;
      if (std::abs(sent.setpoints[s].delta_rad - law.setpoints[s].delta_rad) > 0.5 * can::kDeltaLsb_rad + 1e-9) return false;
    }
    return true;
  }

  ModelFile first_model_, second_model_;
  ModelCommutator first_, second_;
  CommutationOutput first_out_, second_out_;
};

servo::Command load_model(const std::string& path) {
  servo::Command load;
  load.kind = Kind::kLoadModel;
  load.commutation = CommutationMode::kPgnn;
  load.path.assign(path);
  return load;
}

servo::Command fig8() {
  servo::Command run;
  run.kind = Kind::kRunProgram;
  run.program.assign(test::ideal_plant_program("fig8.yaml"));
  return run;
}

struct PgnnRig {
  PgnnRig() : dir("clm-daemon-swap") {
    const auto motor = sim::load_motor_parameters(test::source_path("config/motor-sim.yaml"));
    // Two PGNN models told apart on the bus in every cycle that drives current:
    // the second has 10 % more gain (smaller magnitudes) and a 0.05 rad phase shift.
    first_path = dir.file("pgnn-first.yaml");
    second_path = dir.file("pgnn-second.yaml");
    test::write_text(first_path, format_model_file(test::truth_pgnn(motor)));
    test::write_text(second_path, format_model_file(test::truth_pgnn(motor, 1.1, 0.05)));
    config = test::ideal_plant_config();
    config.commutation.pgnn_model_file = first_path;
    config.commutation.mode = CommutationMode::kPgnn;
    // Commands load files only from the configured directories.
    config.commands.file_directories.push_back(std::filesystem::canonical(dir.path()).string());
  }
  test::TemporaryDirectory dir;
  std::string first_path, second_path;
  servod::ServodConfig config;
};

}  // namespace

TEST_CASE("a model loaded mid-program is swapped in only at standstill after the program", "[daemon][swap]") {
  PgnnRig rig;
  servod::WiredAxis axis(rig.config);
  servod::ServoDaemon& daemon = axis.daemon;
  LawPair laws(rig.config, rig.first_path, rig.second_path);
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 10);
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  REQUIRE(daemon.submit(fig8()).accepted());
  daemon.run_cycles(1);
  REQUIRE(daemon.cycle().record().program_running);
  for (int k = 0; k < 3000; ++k) {  // into the first move of Fig. 8
    daemon.run_cycles(1);
    REQUIRE(laws.used(axis) == Used::kFirst);
  }
  REQUIRE(std::abs(axis.simulated_motor()->truth().velocity_m_per_s) > 0.02);

  const auto reply = daemon.submit(load_model(rig.second_path));
  INFO(reply.text());
  REQUIRE(reply.accepted());
  CHECK(reply.text() == "loaded; swapped in at the next standstill");
  // One load at a time.
  const auto second_reply = daemon.submit(load_model(rig.second_path));
  CHECK_FALSE(second_reply.accepted());
  CHECK(second_reply.text() == "rejected: an earlier load is still waiting for standstill");

  const double standstill_m_per_s = rig.config.servo.standstill_velocity_m_per_s;
  std::int64_t program_end_cycle = -1, swap_cycle = -1;
  for (std::int64_t k = 0; swap_cycle < 0; ++k) {
    REQUIRE(k < 40000);
    const bool running_before = daemon.cycle().record().program_running;
    daemon.run_cycles(1);
    REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
    const Used used = laws.used(axis);
    if (!running_before && program_end_cycle < 0) program_end_cycle = daemon.cycle().record().cycle;
    if (used == Used::kSecond) {
      swap_cycle = daemon.cycle().record().cycle;
      // Adopted at the start of this cycle: the program was over before it,
      // and the translator is at rest (the simulator's truth).
      CHECK_FALSE(running_before);
      CHECK(std::abs(axis.simulated_motor()->truth().velocity_m_per_s) < standstill_m_per_s);
      CHECK(std::abs(axis.simulated_motor()->truth().position_m - (-0.1)) < 20e-6);
    }
  }
  INFO("program over at cycle " << program_end_cycle << ", swap at " << swap_cycle);
  REQUIRE(program_end_cycle > 0);
  CHECK(swap_cycle >= program_end_cycle);
  CHECK(swap_cycle - program_end_cycle < 500);  // the next standstill, not some later one
  for (int k = 0; k < 500; ++k) {
    daemon.run_cycles(1);
    REQUIRE(laws.used(axis) == Used::kSecond);
  }
  CHECK(daemon.law_source(CommutationMode::kPgnn) == rig.second_path);
  // And it drives the next program.
  servo::Command back;
  back.kind = Kind::kMoveTo;
  back.target_m = 0.0;
  REQUIRE(daemon.submit(back).accepted());
  for (int k = 0; k < 1000; ++k) {
    daemon.run_cycles(1);
    REQUIRE(laws.used(axis) == Used::kSecond);
  }
}

TEST_CASE("a model file that does not load leaves the running law untouched and the reply says why",
          "[daemon][swap]") {
  PgnnRig rig;
  const std::string text = format_model_file(
      test::truth_pgnn(sim::load_motor_parameters(test::source_path("config/motor-sim.yaml")), 1.1));
  const std::string corrupt = rig.dir.file("corrupt.yaml");
  test::write_text(corrupt, text.substr(0, text.size() / 2));
  const std::string other_motor = rig.dir.file("pgnn-2coil.yaml");
  test::write_text(other_motor, format_model_file(test::truth_pgnn(
                                    sim::load_motor_parameters(test::source_path("config/motor-sim-2coil.yaml")))));
  const std::string spline = rig.dir.file("spline.yaml");
  test::write_text(spline, format_model_file(test::truth_spline(
                               sim::load_motor_parameters(test::source_path("config/motor-sim.yaml")))));
  const std::string missing = rig.dir.file("no-such-model.yaml");

  servod::WiredAxis axis(rig.config);

  servod::ServoDaemon& daemon = axis.daemon;
  LawPair laws(rig.config, rig.first_path, rig.second_path);
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 10);
  servo::Command move;
  move.kind = Kind::kMoveTo;
  move.target_m = 0.05;
  move.limits = {0.05, 1.0, 1000.0};
  REQUIRE(daemon.submit(move).accepted());
  daemon.run_cycles(200);

  // The reply names the file, and the line and key when the parser gave
  // them, never what the file holds; the parser's whole message goes to the
  // daemon's log.
  std::vector<std::string> log;
  daemon.set_log([&](const std::string& line) { log.push_back(line); });
  const auto refused = [&](const std::string& path) {
    const auto reply = daemon.submit(load_model(path));
    CHECK_FALSE(reply.accepted());
    return reply.text();
  };
  const std::string why = "rejected: load_model: invalid model file (";
  CHECK_THAT(refused(corrupt), Catch::StartsWith(why + "line ") && Catch::EndsWith("): '" + corrupt + "'"));
  REQUIRE(log.size() == 1);
  CHECK_THAT(log[0], Catch::StartsWith("refused model file '" + corrupt + "': " + corrupt + ":"));
  CHECK(refused(other_motor) == why + "key motor.coil_sets): '" + other_motor + "'");
  REQUIRE(log.size() == 2);
  CHECK(log[1] == "refused model file '" + other_motor + "': " + other_motor +
                      ": motor.coil_sets: model has 2 coil sets, " + test::ideal_plant_file("motor-sim.yaml") +
                      " has 3");
  CHECK(refused(spline) == why + "key kind): '" + spline + "'");
  REQUIRE(log.size() == 3);
  CHECK_THAT(log[2], Catch::StartsWith("refused model file '" + spline + "': " + spline +
                                       ": kind: the file holds a spline model"));
  CHECK_THAT(refused(missing), Catch::StartsWith("rejected: ") && Catch::Contains("no-such-model.yaml"));

  // Nothing is waiting: the move ends, the axis comes to rest, and the first
  // law is still the one in use.
  daemon.run_until_idle(10000);
  daemon.run_cycles(1000);
  for (int k = 0; k < 100; ++k) {
    daemon.run_cycles(1);
    REQUIRE(laws.used(axis) == Used::kFirst);
  }
  CHECK(daemon.law_source(CommutationMode::kPgnn) == rig.first_path);
  CHECK(daemon.cycle().status().state == servo::ServoState::kEnabled);
}

TEST_CASE("a commutation change requested mid-move is deferred to standstill", "[daemon][swap]") {
  PgnnRig rig;
  servod::WiredAxis axis(rig.config);
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 10);
  servo::Command move;
  move.kind = Kind::kMoveTo;
  move.target_m = 0.05;
  move.limits = {0.05, 1.0, 1000.0};
  REQUIRE(daemon.submit(move).accepted());
  daemon.run_cycles(200);
  servo::Command set;
  set.kind = Kind::kSetCommutation;
  set.commutation = CommutationMode::kOracle;
  set.sequence = 7;
  REQUIRE(daemon.submit(set).accepted());
  daemon.run_cycles(1);
  const auto replies = daemon.take_replies();
  REQUIRE_FALSE(replies.empty());
  CHECK(replies.back().sequence == 7);
  CHECK(replies.back().accepted());
  CHECK(replies.back().text() == servo::describe(servo::CommandResult::kDeferred));
  bool was_running = true;
  while (daemon.cycle().status().mode == CommutationMode::kPgnn) {
    was_running = daemon.cycle().record().program_running;
    daemon.run_cycles(1);
    REQUIRE(daemon.cycle().status().counters.cycles < 10000);
  }
  CHECK_FALSE(was_running);
  CHECK(std::abs(axis.simulated_motor()->truth().velocity_m_per_s) < rig.config.servo.standstill_velocity_m_per_s);
  CHECK(std::abs(axis.simulated_motor()->truth().position_m - 0.05) < 20e-6);
}
