// The command thread's work: LCM commands translated into DaemonCommands and
// answered by exactly one ack each, on the daemon core in virtual time.
#include <catch2/catch.hpp>

#include <fstream>
#include <map>

#include "daemon/servod/command_server.hpp"
#include "support/temporary_directory.hpp"

using namespace clm;
using namespace clm::servod;
using Kind = DaemonCommand::Kind;
using telemetry::CommandKind;

namespace {

std::string source_path(const std::string& relative) { return std::string(CLM_SOURCE_DIR) + "/" + relative; }

/// config/servod.yaml on the virtual clock, without its own telemetry.
ServodConfig virtual_config() {
  auto config = load_servod_config(source_path("config/servod.yaml"));
  config.loop.clock = ClockMode::kVirtual;
  config.telemetry.enabled = false;
  return config;
}

telemetry::ServoCommand received(CommandKind kind, std::int64_t sequence = 7) {
  telemetry::ServoCommand command;
  command.sequence = sequence;
  command.command = kind;
  return command;
}

clm_lcm::servo_command_t message(std::int8_t kind, std::int64_t sequence) {
  clm_lcm::servo_command_t m{};
  m.sequence = sequence;
  m.command = kind;
  return m;
}

/// A file holding `text` in a directory of its own, removed at the end of the test.
class TemporaryFile {
 public:
  TemporaryFile(const std::string& name, const std::string& text) : path_(directory_.file(name)) {
    std::ofstream(path_) << text;
  }
  const std::string& path() const { return path_; }

 private:
  test::TemporaryDirectory directory_{"clm_servod"};
  std::string path_;
};

/// The acks the publisher sent, by sequence.
std::multimap<std::int64_t, clm_lcm::servo_command_ack_t> acks(const telemetry::MemorySink& sink) {
  std::multimap<std::int64_t, clm_lcm::servo_command_ack_t> out;
  for (const auto& ack : sink.decode<clm_lcm::servo_command_ack_t>(telemetry::kCommandAckChannel)) {
    out.emplace(ack.sequence, ack);
  }
  return out;
}

}  // namespace

TEST_CASE("Every LCM command kind translates into the daemon command of the same meaning", "[servod][commands]") {
  const std::pair<CommandKind, Kind> simple[] = {{CommandKind::kEnable, Kind::kEnable},
                                                 {CommandKind::kDisable, Kind::kDisable},
                                                 {CommandKind::kClearFault, Kind::kClearFault},
                                                 {CommandKind::kStop, Kind::kStop}};
  for (const auto& [from, to] : simple) {
    DaemonCommand out;
    CHECK(to_daemon_command(received(from, 11), out).empty());
    CHECK(out.kind == to);
    CHECK(out.sequence == 11);
    CHECK(answered_by_cycle(out.kind));
  }

  auto move = received(CommandKind::kMoveTo);
  move.target_m = 0.05;
  move.velocity_m_per_s = 0.2;
  move.acceleration_m_per_s2 = 2.0;
  move.jerk_m_per_s3 = 500.0;
  DaemonCommand out;
  REQUIRE(to_daemon_command(move, out).empty());
  CHECK(out.kind == Kind::kMoveTo);
  CHECK(out.target_m == 0.05);
  CHECK(out.limits.velocity_m_per_s == 0.2);
  CHECK(out.limits.acceleration_m_per_s2 == 2.0);
  CHECK(out.limits.jerk_m_per_s3 == 500.0);
  CHECK_FALSE(answered_by_cycle(out.kind));

  auto program = received(CommandKind::kRunProgram);
  program.program.assign("/etc/clm-servo/programs/fig8.yaml");
  REQUIRE(to_daemon_command(program, out).empty());
  CHECK(out.kind == Kind::kRunProgram);
  CHECK(out.path == "/etc/clm-servo/programs/fig8.yaml");

  for (int code = 0; code <= 4; ++code) {
    auto commutation = received(CommandKind::kSetCommutation);
    commutation.commutation = static_cast<std::int8_t>(code);
    REQUIRE(to_daemon_command(commutation, out).empty());
    CHECK(out.kind == Kind::kSetCommutation);
    CHECK(static_cast<int>(out.mode) == code);
  }

  auto experiment = received(CommandKind::kSetExperiment);
  experiment.coil_set = 2;
  experiment.delta_rad = -0.25;
  REQUIRE(to_daemon_command(experiment, out).empty());
  CHECK(out.kind == Kind::kSetExperiment);
  CHECK(out.coil_set == 2);
  CHECK(out.delta_rad == -0.25);

  auto calibration = received(CommandKind::kLoadCalibration);
  calibration.path.assign("/var/lib/clm-servo/calibration.yaml");
  REQUIRE(to_daemon_command(calibration, out).empty());
  CHECK(out.kind == Kind::kLoadCalibration);
  CHECK(out.path == "/var/lib/clm-servo/calibration.yaml");
}

TEST_CASE("set_commutation to experiment and move_to without positive limits are refused with the reason",
          "[servod][commands]") {
  DaemonCommand out;
  auto commutation = received(CommandKind::kSetCommutation);
  commutation.commutation = 5;
  CHECK_THAT(to_daemon_command(commutation, out), Catch::Contains("experiments use set_experiment"));

  auto move = received(CommandKind::kMoveTo);
  move.velocity_m_per_s = 0.1;
  move.acceleration_m_per_s2 = 0.0;
  move.jerk_m_per_s3 = 1000.0;
  CHECK_THAT(to_daemon_command(move, out), Catch::Contains("acceleration_m_per_s2 must be positive"));
}

TEST_CASE("load_model loads into the law the model file's kind names", "[servod][commands]") {
  const TemporaryFile pgnn("pgnn.yaml", "format: clm-servo-model\nkind: pgnn\n");
  const TemporaryFile spline("spline.yaml", "format: clm-servo-model\nkind: spline\n");
  const TemporaryFile other("other.yaml", "format: clm-servo-model\nkind: table\n");
  DaemonCommand out;
  auto load = received(CommandKind::kLoadModel);
  load.path.assign(pgnn.path());
  REQUIRE(to_daemon_command(load, out).empty());
  CHECK(out.kind == Kind::kLoadModel);
  CHECK(out.mode == servo::CommutationMode::kPgnn);
  CHECK(out.path == pgnn.path());

  load.path.assign(spline.path());
  REQUIRE(to_daemon_command(load, out).empty());
  CHECK(out.mode == servo::CommutationMode::kSpline);

  load.path.assign(other.path());
  CHECK_THAT(to_daemon_command(load, out), Catch::Contains("kind: expected pgnn or spline, got 'table'"));

  load.path.assign("/nonexistent/model.yaml");
  CHECK_THAT(to_daemon_command(load, out), Catch::Contains("/nonexistent/model.yaml"));
}

TEST_CASE("Each command gets exactly one ack: queued ones with the cycle's decision, others at once",
          "[servod][commands]") {
  ServoDaemon daemon(virtual_config());
  telemetry::MemorySink sink;
  telemetry::TelemetryPublisher publisher(telemetry::TelemetryConfig{}, sink);
  CommandServer server(publisher, daemon);

  // enable: queued, so no ack until the cycle has run it.
  REQUIRE(publisher.submit_command(message(clm_lcm::servo_command_t::ENABLE, 1)));
  server.serve_once();
  CHECK(acks(sink).count(1) == 0);
  daemon.run_cycles(1);
  server.serve_once();
  REQUIRE(acks(sink).count(1) == 1);
  CHECK(acks(sink).find(1)->second.accepted);
  CHECK(daemon.cycle().state() == servo::ServoState::kEnabled);

  // pgnn without a model: the cycle refuses it, and says why.
  auto pgnn = message(clm_lcm::servo_command_t::SET_COMMUTATION, 2);
  pgnn.commutation = clm_lcm::servo_state_t::COMMUTATION_PGNN;
  REQUIRE(publisher.submit_command(pgnn));
  server.serve_once();
  daemon.run_cycles(1);
  server.serve_once();
  REQUIRE(acks(sink).count(2) == 1);
  CHECK_FALSE(acks(sink).find(2)->second.accepted);
  CHECK_THAT(acks(sink).find(2)->second.text, Catch::Contains("no calibration or model"));

  // move_to: answered by submit itself.
  auto move = message(clm_lcm::servo_command_t::MOVE_TO, 3);
  move.target_m = 0.01;
  move.velocity_m_per_s = 0.1;
  move.acceleration_m_per_s2 = 1.0;
  move.jerk_m_per_s3 = 1000.0;
  REQUIRE(publisher.submit_command(move));
  server.serve_once();
  REQUIRE(acks(sink).count(3) == 1);
  CHECK(acks(sink).find(3)->second.accepted);
  CHECK(acks(sink).find(3)->second.text == "program posted");
  daemon.run_until_idle(5000);
  CHECK(daemon.cycle().record().position_m == Approx(0.01).margin(5e-4));

  // A target beyond the soft limits, and a translation refusal.
  move.sequence = 4;
  move.target_m = 1.0;
  REQUIRE(publisher.submit_command(move));
  auto experiment_mode = message(clm_lcm::servo_command_t::SET_COMMUTATION, 5);
  experiment_mode.commutation = clm_lcm::servo_state_t::COMMUTATION_EXPERIMENT;
  REQUIRE(publisher.submit_command(experiment_mode));
  server.serve_once();
  daemon.run_cycles(2);
  server.serve_once();
  const auto all = acks(sink);
  CHECK(all.size() == 5);
  for (std::int64_t sequence = 1; sequence <= 5; ++sequence) CHECK(all.count(sequence) == 1);
  CHECK(all.find(4)->second.text == "rejected: target outside the soft limits");
  CHECK_THAT(all.find(5)->second.text, Catch::StartsWith("rejected: set_commutation"));
  CHECK(server.commands_served() == 5);
}

TEST_CASE("load_feedforward reads the file off the cycle, the cycle applies its parameters, and acks once",
          "[servod][commands]") {
  const TemporaryFile file("ff.yaml",
                           "format: clm-servo-feedforward\nformat_version: 1\nmass_kg: 2.0\n"
                           "viscous_N_s_per_m: 10.0\ncoulomb_N: 3.0\n");
  const TemporaryFile wrong("ff-wrong.yaml", "format: clm-servo-model\nformat_version: 1\n");

  // Translation: the file is read here, the parameters travel in the command.
  DaemonCommand out;
  auto load = received(CommandKind::kLoadFeedforward, 21);
  load.path.assign(file.path());
  REQUIRE(to_daemon_command(load, out).empty());
  CHECK(out.kind == Kind::kSetFeedforward);
  CHECK(out.sequence == 21);
  CHECK(out.feedforward.mass_kg == 2.0);
  CHECK(out.feedforward.viscous_N_s_per_m == 10.0);
  CHECK(out.feedforward.coulomb_N == 3.0);
  CHECK(answered_by_cycle(out.kind));
  load.path.assign("/nonexistent/ff.yaml");
  CHECK_THAT(to_daemon_command(load, out), Catch::StartsWith("load_feedforward: /nonexistent/ff.yaml"));
  load.path.assign(wrong.path());
  CHECK_THAT(to_daemon_command(load, out), Catch::Contains(wrong.path()));

  // End to end: over the publisher's command path into the running cycle.
  ServoDaemon daemon(virtual_config());
  telemetry::MemorySink sink;
  telemetry::TelemetryPublisher publisher(telemetry::TelemetryConfig{}, sink);
  CommandServer server(publisher, daemon);
  REQUIRE(publisher.submit_command(message(clm_lcm::servo_command_t::ENABLE, 1)));
  server.serve_once();
  daemon.run_cycles(1);
  server.serve_once();
  auto ff = message(clm_lcm::servo_command_t::LOAD_FEEDFORWARD, 2);
  ff.path = file.path();
  REQUIRE(publisher.submit_command(ff));
  server.serve_once();
  CHECK(acks(sink).count(2) == 0);  // queued: acked with the cycle's decision
  daemon.run_cycles(1);
  server.serve_once();
  REQUIRE(acks(sink).count(2) == 1);
  CHECK(acks(sink).find(2)->second.accepted);

  // At the cruise velocity of a move, eq. (40) gives viscous·v + coulomb = 10·0.1 + 3 = 4 N.
  auto move = message(clm_lcm::servo_command_t::MOVE_TO, 3);
  move.target_m = 0.08;
  move.velocity_m_per_s = 0.1;
  move.acceleration_m_per_s2 = 1.0;
  move.jerk_m_per_s3 = 1000.0;
  REQUIRE(publisher.submit_command(move));
  server.serve_once();
  REQUIRE(acks(sink).find(3)->second.accepted);
  daemon.run_cycles(400);
  const auto& record = daemon.cycle().record();
  REQUIRE(record.reference.velocity_m_per_s == Approx(0.1).margin(1e-9));
  REQUIRE(record.reference.acceleration_m_per_s2 == Approx(0.0).margin(1e-9));
  CHECK(record.feedforward_N == Approx(4.0).margin(1e-6));

  // A missing file is refused at once, and the running feedforward stays.
  ff.sequence = 4;
  ff.path = "/nonexistent/ff.yaml";
  REQUIRE(publisher.submit_command(ff));
  server.serve_once();
  REQUIRE(acks(sink).count(4) == 1);
  CHECK_FALSE(acks(sink).find(4)->second.accepted);
  CHECK_THAT(acks(sink).find(4)->second.text, Catch::StartsWith("rejected: load_feedforward: /nonexistent/ff.yaml"));
  daemon.run_cycles(1);
  CHECK(daemon.cycle().record().feedforward_N == Approx(4.0).margin(1e-6));
}
