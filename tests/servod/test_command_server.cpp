// The command thread's work: checked LCM commands completed by check_command,
// submitted, and answered by exactly one ack each, on the daemon core in
// virtual time.
#include <catch2/catch.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "daemon/servod/axis_wiring.hpp"
#include "daemon/servod/command_check.hpp"
#include "daemon/servod/command_server.hpp"
#include "tools/servod_client/client.hpp"
#include "support/ideal_plant.hpp"
#include "support/temporary_directory.hpp"

using namespace clm;
using namespace clm::servod;
namespace fs = std::filesystem;
using servo::CommandKind;
using servo::answered_by_cycle;

namespace {

/// config/servod.yaml (its encoder absolute) on the virtual clock, without its own telemetry.
ServodConfig virtual_config() {
  auto config = load_servod_config(clm::test::absolute_encoder_path());
  config.loop.clock = ClockMode::kVirtual;
  config.telemetry.enabled = false;
  return config;
}

servo::Command received(CommandKind kind, std::int64_t sequence = 7) {
  servo::Command command;
  command.sequence = sequence;
  command.kind = kind;
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

TEST_CASE("Every command kind passes check_command with its meaning kept", "[servod][commands]") {
  const CommandKind simple[] = {CommandKind::kEnable, CommandKind::kDisable, CommandKind::kClearFault,
                                CommandKind::kStop};
  for (const auto kind : simple) {
    servo::Command out = received(kind, 11);
    CHECK(check_command(out).empty());
    CHECK(out.kind == kind);
    CHECK(out.sequence == 11);
    CHECK(answered_by_cycle(out.kind));
  }

  servo::Command out = received(CommandKind::kMoveTo);
  out.target_m = 0.05;
  out.limits = {0.2, 2.0, 500.0};
  REQUIRE(check_command(out).empty());
  CHECK(out.kind == CommandKind::kMoveTo);
  CHECK(out.target_m == 0.05);
  CHECK(out.limits.velocity_m_per_s == 0.2);
  CHECK(out.limits.acceleration_m_per_s2 == 2.0);
  CHECK(out.limits.jerk_m_per_s3 == 500.0);
  CHECK(answered_by_cycle(out.kind));  // decided by the daemon, answered once the cycle has taken it

  out = received(CommandKind::kRunProgram);
  out.program.assign("/etc/clm-servo/programs/fig8.yaml");
  REQUIRE(check_command(out).empty());
  CHECK(out.kind == CommandKind::kRunProgram);
  CHECK(out.program.view() == "/etc/clm-servo/programs/fig8.yaml");
  CHECK(answered_by_cycle(out.kind));

  for (int code = 0; code <= 4; ++code) {
    out = received(CommandKind::kSetCommutation);
    out.commutation = static_cast<servo::CommutationMode>(code);
    REQUIRE(check_command(out).empty());
    CHECK(out.kind == CommandKind::kSetCommutation);
    CHECK(static_cast<int>(out.commutation) == code);
    CHECK(answered_by_cycle(out.kind));
  }

  out = received(CommandKind::kSetExperiment);
  out.commutation = servo::CommutationMode::kExperiment;
  out.coil_set = 2;
  out.delta_rad = -0.25;
  REQUIRE(check_command(out).empty());
  CHECK(out.kind == CommandKind::kSetExperiment);
  CHECK(out.coil_set == 2);
  CHECK(out.delta_rad == -0.25);
  CHECK(answered_by_cycle(out.kind));

  out = received(CommandKind::kLoadCalibration);
  out.path.assign("/var/lib/clm-servo/calibration.yaml");
  REQUIRE(check_command(out).empty());
  CHECK(out.kind == CommandKind::kLoadCalibration);
  CHECK(out.path.view() == "/var/lib/clm-servo/calibration.yaml");
  CHECK_FALSE(answered_by_cycle(out.kind));
}

TEST_CASE("The route table names every kind once, in the order of its LCM value", "[servod][commands]") {
  for (int code = 1; code <= servo::kCommandKinds; ++code) {
    const auto kind = static_cast<CommandKind>(code);
    CHECK(static_cast<int>(servo::route(kind).kind) == code);
  }
  CHECK(servo::is_command_kind(servo::kCommandKinds));
  CHECK_FALSE(servo::is_command_kind(0));
  CHECK_FALSE(servo::is_command_kind(servo::kCommandKinds + 1));
  for (const auto kind : {CommandKind::kLoadCalibration, CommandKind::kLoadModel, CommandKind::kGetParameter}) {
    CHECK_FALSE(answered_by_cycle(kind));
  }
  for (const auto kind : {CommandKind::kMoveTo, CommandKind::kRunProgram, CommandKind::kJog,
                          CommandKind::kLoadFeedforward, CommandKind::kSetParameter}) {
    CHECK(answered_by_cycle(kind));
  }
}

TEST_CASE("The command table decides class, file and legal states, the gate, the daemon and the client read it",
          "[servod][commands]") {
  using servo::CommandClass;
  using servo::CommandResult;
  using servo::ServoState;
  // Classes: the three safety kinds, one read, take, release and renew, and every
  // other kind controlled; the client takes control exactly for those.
  int controlled = 0;
  for (int code = 1; code <= servo::kCommandKinds; ++code) {
    const auto kind = static_cast<CommandKind>(code);
    const bool is_controlled = command_class(kind) == CommandClass::kControlled;
    controlled += is_controlled ? 1 : 0;
    CHECK(servod_client::needs_control(kind) == is_controlled);
  }
  CHECK(controlled == servo::kCommandKinds - 7);  // 3 safety, 1 read, take, release, renew
  CHECK(command_class(CommandKind::kQuickStop) == CommandClass::kSafety);
  CHECK(command_class(CommandKind::kGetParameter) == CommandClass::kRead);
  CHECK(command_class(CommandKind::kJog) == CommandClass::kControlled);

  // Files: run_program names its program, the loads a path; feedforward only with one.
  servo::Command command = received(CommandKind::kRunProgram);
  command.program.assign("/p.yaml");
  CHECK(servo::reads_file(command));
  CHECK(servo::file_named(command) == "/p.yaml");
  command = received(CommandKind::kLoadFeedforward);
  CHECK_FALSE(servo::reads_file(command));
  command.path.assign("/ff.yaml");
  CHECK(servo::reads_file(command));
  CHECK(servo::file_named(command) == "/ff.yaml");
  for (const servo::CommandRoute& route : servo::kCommandRoutes) {
    INFO(route.name);
    // The loader answers only kinds with a file, and every kind with a file says what it holds.
    if (route.answered_by == servo::AnsweredBy::kLoader) CHECK(route.file != servo::FileUse::kNone);
    CHECK((route.file == servo::FileUse::kNone) == std::string(route.file_kind).empty());
  }
  CHECK(servo::route(CommandKind::kLoadModel).answered_by == servo::AnsweredBy::kLoader);
  CHECK(std::string(servo::route(CommandKind::kLoadModel).file_kind) == "model");
  CHECK(std::string(servo::route(CommandKind::kRunProgram).file_kind) == "program");
  command = received(CommandKind::kMoveTo);
  CHECK_FALSE(servo::reads_file(command));
  CHECK(servo::file_named(command).empty());

  // Legal states: moves only enabled (and, but a jog, at rest); parameters at rest; stops always.
  CHECK(servo::check_legal(CommandKind::kMoveTo, ServoState::kFault, true) == CommandResult::kRejectedFault);
  CHECK(servo::check_legal(CommandKind::kRunProgram, ServoState::kDisabled, true) == CommandResult::kRejectedDisabled);
  CHECK(servo::check_legal(CommandKind::kMoveTo, ServoState::kEnabled, false) == CommandResult::kRejectedBusy);
  CHECK(servo::check_legal(CommandKind::kMoveTo, ServoState::kEnabled, true) == CommandResult::kAccepted);
  CHECK(servo::check_legal(CommandKind::kJog, ServoState::kEnabled, false) == CommandResult::kAccepted);
  CHECK(servo::check_legal(CommandKind::kSetParameter, ServoState::kFault, false) == CommandResult::kRejectedBusy);
  CHECK(servo::check_legal(CommandKind::kSetParameter, ServoState::kFault, true) == CommandResult::kAccepted);
  for (const auto state : {ServoState::kDisabled, ServoState::kEnabled, ServoState::kFault}) {
    for (const auto kind : {CommandKind::kStop, CommandKind::kQuickStop, CommandKind::kDisable, CommandKind::kEnable,
                            CommandKind::kClearFault}) {
      CHECK(servo::check_legal(kind, state, false) == CommandResult::kAccepted);
    }
  }
  // Each refusal's words, once.
  CHECK(std::string(servo::describe(CommandResult::kRejectedFault)) == "a fault is latched, clear it first");
  CHECK(std::string(servo::describe(CommandResult::kRejectedDisabled)) == "the axis is disabled, enable first");
}

TEST_CASE("set_commutation to experiment and move_to without positive limits are refused with the reason",
          "[servod][commands]") {
  auto commutation = received(CommandKind::kSetCommutation);
  commutation.commutation = servo::CommutationMode::kExperiment;
  CHECK_THAT(check_command(commutation), Catch::Contains("experiments use set_experiment"));

  auto move = received(CommandKind::kMoveTo);
  move.limits = {0.1, 0.0, 1000.0};
  CHECK_THAT(check_command(move), Catch::Contains("acceleration_m_per_s2 must be positive"));
}

TEST_CASE("load_model loads into the law the model file's kind names", "[servod][commands]") {
  const TemporaryFile pgnn("pgnn.yaml", "format: clm-servo-model\nkind: pgnn\n");
  const TemporaryFile spline("spline.yaml", "format: clm-servo-model\nkind: spline\n");
  const TemporaryFile other("other.yaml", "format: clm-servo-model\nkind: table\n");
  auto load = received(CommandKind::kLoadModel);  // as from LCM: no law named
  load.path.assign(pgnn.path());
  servo::Command out = load;
  REQUIRE(check_command(out).empty());
  CHECK(out.kind == CommandKind::kLoadModel);
  CHECK(out.commutation == servo::CommutationMode::kPgnn);
  CHECK(out.path.view() == pgnn.path());

  load.path.assign(spline.path());
  out = load;
  REQUIRE(check_command(out).empty());
  CHECK(out.commutation == servo::CommutationMode::kSpline);

  load.path.assign(other.path());
  out = load;
  CHECK_THAT(check_command(out), Catch::Contains("kind: expected pgnn or spline, got 'table'"));

  load.path.assign("/nonexistent/model.yaml");
  out = load;
  CHECK_THAT(check_command(out), Catch::Contains("/nonexistent/model.yaml"));
}

TEST_CASE("Each command gets exactly one ack: queued ones with the cycle's decision, others at once",
          "[servod][commands]") {
  WiredAxis axis(virtual_config());
  ServoDaemon& daemon = axis.daemon;
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
  CHECK(daemon.cycle().status().state == servo::ServoState::kEnabled);

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

  // move_to: decided by submit, answered once the cycle has taken its program.
  auto move = message(clm_lcm::servo_command_t::MOVE_TO, 3);
  move.target_m = 0.01;
  move.velocity_m_per_s = 0.1;
  move.acceleration_m_per_s2 = 1.0;
  move.jerk_m_per_s3 = 1000.0;
  REQUIRE(publisher.submit_command(move));
  server.serve_once();
  CHECK(acks(sink).count(3) == 0);
  daemon.run_cycles(1);
  server.serve_once();
  REQUIRE(acks(sink).count(3) == 1);
  CHECK(acks(sink).find(3)->second.accepted);
  CHECK(acks(sink).find(3)->second.text == "program posted");
  daemon.run_until_idle(5000);
  CHECK(daemon.cycle().record().y_m == Approx(0.01).margin(5e-4));

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
  CHECK(all.find(4)->second.text == "rejected: move_to: target_m 1 m lies outside the soft limits [-0.11, 0.11] m");
  CHECK_THAT(all.find(5)->second.text, Catch::StartsWith("rejected: set_commutation"));
  CHECK(server.commands_served() == 5);
}

TEST_CASE("load_feedforward reads the file off the cycle, the cycle applies its parameters, and acks once",
          "[servod][commands]") {
  const TemporaryFile file("ff.yaml",
                           "format: clm-servo-feedforward\nformat_version: 1\nmass_kg: 2.0\n"
                           "viscous_N_s_per_m: 10.0\ncoulomb_N: 3.0\n");
  const TemporaryFile wrong("ff-wrong.yaml", "format: clm-servo-model\nformat_version: 1\n");

  // Checking: the file is read here, the parameters travel in the command.
  auto load = received(CommandKind::kLoadFeedforward, 21);
  load.path.assign(file.path());
  servo::Command out = load;
  REQUIRE(check_command(out).empty());
  CHECK(out.kind == CommandKind::kLoadFeedforward);
  CHECK(out.sequence == 21);
  CHECK(out.feedforward.mass_kg == 2.0);
  CHECK(out.feedforward.viscous_N_s_per_m == 10.0);
  CHECK(out.feedforward.coulomb_N == 3.0);
  CHECK(answered_by_cycle(out.kind));
  load.path.assign("/nonexistent/ff.yaml");
  out = load;
  CHECK_THAT(check_command(out), Catch::StartsWith("load_feedforward: /nonexistent/ff.yaml"));
  load.path.assign(wrong.path());
  out = load;
  CHECK_THAT(check_command(out), Catch::Contains(wrong.path()));

  // End to end: over the publisher's command path into the running cycle;
  // commands load files only from the configured directories.
  ServodConfig config = virtual_config();
  config.commands.file_directories.push_back(std::filesystem::canonical(std::filesystem::path(file.path()).parent_path()).string());
  WiredAxis axis(config);
  ServoDaemon& daemon = axis.daemon;
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
  daemon.run_cycles(1);
  server.serve_once();
  REQUIRE(acks(sink).count(3) == 1);
  REQUIRE(acks(sink).find(3)->second.accepted);
  daemon.run_cycles(399);
  const auto& record = daemon.cycle().record();
  REQUIRE(record.r_dot_m_per_s == Approx(0.1).margin(1e-9));
  REQUIRE(record.r_ddot_m_per_s2 == Approx(0.0).margin(1e-9));
  CHECK(record.u_ff_N == Approx(4.0).margin(1e-6));

  // A missing file is refused at once, and the running feedforward stays.
  ff.sequence = 4;
  ff.path = "/nonexistent/ff.yaml";
  REQUIRE(publisher.submit_command(ff));
  server.serve_once();
  REQUIRE(acks(sink).count(4) == 1);
  CHECK_FALSE(acks(sink).find(4)->second.accepted);
  CHECK_THAT(acks(sink).find(4)->second.text, Catch::StartsWith("rejected: load_feedforward: ") && Catch::EndsWith(": '/nonexistent/ff.yaml'"));
  daemon.run_cycles(1);
  CHECK(daemon.cycle().record().u_ff_N == Approx(4.0).margin(1e-6));
}

namespace {

/// A command of client `client` for the gate's axis and session, sent now.
clm_lcm::servo_command_t authored(std::int8_t kind, std::int64_t sequence, std::int64_t client,
                                  std::int64_t session = 77, const std::string& axis = "axis0") {
  clm_lcm::servo_command_t m = message(kind, sequence);
  m.utime = telemetry::wall_clock_utime();
  m.axis = axis;
  m.session = session;
  m.client = client;
  return m;
}

}  // namespace

TEST_CASE("With command authority, the server admits through the gate, answers take/release and counts every refusal",
          "[servod][commands][authority]") {
  using C = clm_lcm::servo_command_t;
  WiredAxis axis(virtual_config());
  ServoDaemon& daemon = axis.daemon;
  telemetry::MemorySink sink;
  telemetry::TelemetryPublisher publisher(telemetry::TelemetryConfig{}, sink);
  CommandServer server(publisher, daemon, CommandGateSettings{"axis0", 77, 2.0, 30.0});
  REQUIRE(server.gate() != nullptr);
  const auto serve = [&] {
    server.serve_once();
    daemon.run_cycles(1);
    server.serve_once();
  };

  // Enable without control: refused by the gate, never reaches the cycle.
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 1, 5)));
  serve();
  REQUIRE(acks(sink).count(1) == 1);
  CHECK_FALSE(acks(sink).find(1)->second.accepted);
  CHECK_THAT(acks(sink).find(1)->second.text, Catch::StartsWith("rejected: not_in_control: take control first"));
  CHECK(daemon.cycle().status().state == servo::ServoState::kDisabled);

  // Take control, enable: both accepted; the ack names the client, axis and session.
  REQUIRE(publisher.submit_command(authored(C::TAKE_CONTROL, 2, 5)));
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 3, 5)));
  serve();
  REQUIRE(acks(sink).count(2) == 1);
  CHECK(acks(sink).find(2)->second.accepted);
  CHECK_THAT(acks(sink).find(2)->second.text, Catch::StartsWith("control taken"));
  REQUIRE(acks(sink).count(3) == 1);
  CHECK(acks(sink).find(3)->second.accepted);
  CHECK(acks(sink).find(3)->second.client == 5);
  CHECK(daemon.cycle().status().state == servo::ServoState::kEnabled);

  // Another client: move refused, stop and disable obeyed; control stays with 5.
  auto move = authored(C::MOVE_TO, 4, 6);
  move.target_m = 0.01;
  move.velocity_m_per_s = 0.1;
  move.acceleration_m_per_s2 = 1.0;
  move.jerk_m_per_s3 = 1000.0;
  REQUIRE(publisher.submit_command(move));
  REQUIRE(publisher.submit_command(authored(C::STOP, 5, 6)));
  REQUIRE(publisher.submit_command(authored(C::DISABLE, 6, 6)));
  serve();
  CHECK_THAT(acks(sink).find(4)->second.text, Catch::StartsWith("rejected: not_in_control: client 5 holds control"));
  CHECK(acks(sink).find(5)->second.accepted);
  CHECK(acks(sink).find(6)->second.accepted);
  CHECK(daemon.cycle().status().state == servo::ServoState::kDisabled);

  // Replayed, other session, other axis, client 0, stale; then a daemon refusal.
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 3, 5)));
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 7, 5, 78)));
  REQUIRE(publisher.submit_command(authored(C::STOP, 8, 6, 77, "axis1")));
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 9, 0)));
  auto stale = authored(C::ENABLE, 10, 5);
  stale.utime -= 10'000'000;
  REQUIRE(publisher.submit_command(stale));
  auto beyond = authored(C::MOVE_TO, 11, 5);
  beyond.target_m = 1.0;
  beyond.velocity_m_per_s = 0.1;
  beyond.acceleration_m_per_s2 = 1.0;
  beyond.jerk_m_per_s3 = 1000.0;
  REQUIRE(publisher.submit_command(beyond));
  // release by 6 (not the holder) refused, by 5 accepted.
  REQUIRE(publisher.submit_command(authored(C::RELEASE_CONTROL, 12, 6)));
  REQUIRE(publisher.submit_command(authored(C::RELEASE_CONTROL, 13, 5)));
  // Stop and disable need only the axis: a repeat, client 0, another session, a stale one are obeyed.
  REQUIRE(publisher.submit_command(authored(C::DISABLE, 6, 6)));
  auto anyone = authored(C::STOP, 14, 0, 78);
  anyone.utime -= 10'000'000;
  REQUIRE(publisher.submit_command(anyone));
  serve();
  const auto all = acks(sink);
  CHECK_THAT(all.find(7)->second.text, Catch::StartsWith("rejected: other_session"));
  CHECK_THAT(all.find(8)->second.text, Catch::StartsWith("rejected: other_axis"));
  CHECK_THAT(all.find(9)->second.text, Catch::StartsWith("rejected: no_client"));
  CHECK_THAT(all.find(10)->second.text, Catch::StartsWith("rejected: stale"));
  // Admitted by the authority, refused by the daemon: the axis was disabled by
  // the other client's DISABLE above, which the daemon checks first.
  CHECK(all.find(11)->second.text == "rejected: the axis is disabled, enable first");
  CHECK_THAT(all.find(12)->second.text, Catch::StartsWith("rejected: not_in_control"));
  CHECK(all.find(13)->second.text == "control released");
  REQUIRE(all.count(6) == 2);  // the disable and its repeat: both obeyed
  for (auto [it, end] = all.equal_range(6); it != end; ++it) CHECK(it->second.accepted);
  REQUIRE(all.count(14) == 1);
  CHECK(all.find(14)->second.accepted);
  REQUIRE(all.count(3) == 2);  // the enable, and its replay's refusal
  int replay_refusals = 0;
  for (auto [it, end] = all.equal_range(3); it != end; ++it) {
    if (it->second.text.rfind("rejected: replayed", 0) == 0) ++replay_refusals;
  }
  CHECK(replay_refusals == 1);

  telemetry::CommandAuthorityStatus status;
  server.fill(status);
  CHECK(status.control_client == 0);
  CHECK(status.control_lease_remaining_s == 0.0);
  // take, enable (5); stop, disable (6); the move beyond the limits, release (5); disable again (6); stop (0)
  CHECK(status.admitted == 8);
  CHECK(status.refused_not_in_control == 3);
  CHECK(status.refused_replayed == 1);
  CHECK(status.refused_other_session == 1);
  CHECK(status.refused_other_axis == 1);
  CHECK(status.refused_no_client == 1);
  CHECK(status.refused_stale == 1);
  CHECK(daemon.commands_refused() == 1);  // the status takes it from the daemon (TelemetryBridge)
  CHECK(status.refused_malformed == 0);
}

TEST_CASE("Disable through the safety latch: obeyed by the next cycle with the command queue full and the command "
          "thread idle, acked after it",
          "[servod][commands][authority][safety]") {
  using C = clm_lcm::servo_command_t;
  WiredAxis axis(virtual_config());
  ServoDaemon& daemon = axis.daemon;
  telemetry::MemorySink sink;
  telemetry::TelemetryConfig config;
  config.command_queue_capacity = 2;
  telemetry::TelemetryPublisher publisher(config, sink);
  CommandServer server(publisher, daemon, CommandGateSettings{"axis0", 77, 2.0, 30.0});
  publisher.set_safety_latch(server);
  REQUIRE(publisher.submit_command(authored(C::TAKE_CONTROL, 1, 5)));
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 2, 5)));
  server.serve_once();
  daemon.run_cycles(1);
  server.serve_once();
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  // Fill the command queue (nobody serves it now), then disable from a client 0 of another session.
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 3, 5)));
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 4, 5)));
  REQUIRE_FALSE(publisher.submit_command(authored(C::ENABLE, 5, 5)));
  REQUIRE(publisher.submit_command(authored(C::DISABLE, 6, 0, 78)));
  CHECK(acks(sink).count(6) == 0);  // not before a cycle obeyed it
  daemon.run_cycles(1);
  CHECK(daemon.cycle().status().state == servo::ServoState::kDisabled);
  publisher.flush_safety_acks();
  REQUIRE(acks(sink).count(6) == 1);
  CHECK(acks(sink).find(6)->second.accepted);
  CHECK(acks(sink).find(6)->second.text == "accepted");
  // Another axis's disable is not latched: it takes the ordinary way, to its refusal.
  CHECK(server.latch([] {
          servo::Command other;
          other.kind = servo::CommandKind::kDisable;
          other.axis.assign("axis1");
          return other;
        }()) == 0);
}

TEST_CASE("Without command authority, take and release control are refused and other commands pass",
          "[servod][commands][authority]") {
  WiredAxis axis(virtual_config());
  telemetry::MemorySink sink;
  telemetry::TelemetryPublisher publisher(telemetry::TelemetryConfig{}, sink);
  CommandServer server(publisher, axis.daemon);
  CHECK(server.gate() == nullptr);
  REQUIRE(publisher.submit_command(message(clm_lcm::servo_command_t::TAKE_CONTROL, 1)));
  server.serve_once();
  REQUIRE(acks(sink).count(1) == 1);
  CHECK_FALSE(acks(sink).find(1)->second.accepted);
  CHECK_THAT(acks(sink).find(1)->second.text, Catch::Contains("no command authority"));
  CHECK(command_class(CommandKind::kStop) == CommandClass::kSafety);
  CHECK(command_class(CommandKind::kDisable) == CommandClass::kSafety);
  CHECK(command_class(CommandKind::kClearFault) == CommandClass::kControlled);
  CHECK(command_class(CommandKind::kTakeControl) == CommandClass::kTakeControl);
  CHECK(command_class(CommandKind::kReleaseControl) == CommandClass::kReleaseControl);
  CHECK(servo::route(CommandKind::kTakeControl).answered_by == servo::AnsweredBy::kAuthority);
  CHECK(servo::route(CommandKind::kReleaseControl).answered_by == servo::AnsweredBy::kAuthority);
}

TEST_CASE("A deadman lease that lapses stops the axis, ends the experiment and releases control, renewals keep it",
          "[servod][commands][authority][deadman]") {
  using C = clm_lcm::servo_command_t;
  WiredAxis axis(virtual_config());
  ServoDaemon& daemon = axis.daemon;
  const servo::CommutationMode service = daemon.config().commutation.mode;
  telemetry::MemorySink sink;
  telemetry::TelemetryPublisher publisher(telemetry::TelemetryConfig{}, sink);
  constexpr double kDeadman_s = 0.5;
  CommandServer server(publisher, daemon, CommandGateSettings{"axis0", 77, 2.0, 30.0, kDeadman_s});
  const auto serve = [&] {
    server.serve_once();
    daemon.run_cycles(1);
    server.serve_once();
  };
  daemon.run_cycles(10);
  REQUIRE(publisher.submit_command(authored(C::TAKE_CONTROL, 1, 5)));
  REQUIRE(publisher.submit_command(authored(C::RENEW_CONTROL, 1, 5)));  // no sequence kept: not a replay
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 2, 5)));
  auto experiment = authored(C::SET_EXPERIMENT, 3, 5);
  experiment.coil_set = 1;
  experiment.delta_rad = -0.785;
  REQUIRE(publisher.submit_command(experiment));
  serve();
  daemon.run_cycles(2);
  serve();
  {
    const auto all = acks(sink);
    REQUIRE(all.count(1) == 2);
    for (auto [it, end] = all.equal_range(1); it != end; ++it) CHECK(it->second.accepted);
    REQUIRE(all.count(3) == 1);
    CHECK(all.find(3)->second.accepted);
  }
  REQUIRE(daemon.cycle().status().mode == servo::CommutationMode::kExperiment);
  REQUIRE(server.gate()->deadman());
  // A slow move that runs for seconds of virtual time.
  auto move = authored(C::MOVE_TO, 4, 5);
  move.target_m = daemon.cycle().mailbox().hold_position_m() + 0.02;
  move.velocity_m_per_s = 0.01;
  move.acceleration_m_per_s2 = 0.1;
  move.jerk_m_per_s3 = 100.0;
  REQUIRE(publisher.submit_command(move));
  serve();
  daemon.run_cycles(20);
  REQUIRE(daemon.cycle().record().program_running);

  // Renewed every half deadman for two deadmen: still held, nothing stopped.
  for (int k = 0; k < 4; ++k) {
    std::this_thread::sleep_for(std::chrono::duration<double>(kDeadman_s / 2));
    REQUIRE(publisher.submit_command(authored(C::RENEW_CONTROL, 2, 5)));
    serve();
  }
  CHECK(server.gate()->holder(telemetry::wall_clock_utime()) == 5);
  CHECK(server.deadman_lapses() == 0);
  CHECK(daemon.cycle().record().program_running);

  // Silence for more than the deadman: lapsed once, control free, the program stopped.
  std::this_thread::sleep_for(std::chrono::duration<double>(kDeadman_s * 1.5));
  server.serve_once();
  CHECK(server.deadman_lapses() == 1);
  CHECK(server.gate()->holder(telemetry::wall_clock_utime()) == 0);
  const auto events = sink.decode<clm_lcm::servo_event_t>(telemetry::kEventChannel);
  REQUIRE_FALSE(events.empty());
  CHECK_THAT(events.back().text, Catch::Contains("client 5") && Catch::Contains("deadman"));
  daemon.run_cycles(1);
  CHECK_FALSE(daemon.cycle().record().program_running);
  CHECK(daemon.cycle().status().stopping);
  {
    // The quick stop is driven by the service law from its first cycle, not
    // by the experiment's one coil set at its offset angle.
    INFO("commutation while stopping: " << servo::name(daemon.cycle().status().mode));
    CHECK(daemon.cycle().status().mode == service);
    CHECK(daemon.cycle().record().commutation == service);
    CHECK(daemon.cycle().record().coil_set == 0);
  }
  daemon.run_cycles(2000);  // the quick stop ends; the service law at standstill
  CHECK(daemon.cycle().status().state == servo::ServoState::kEnabled);
  CHECK_FALSE(daemon.cycle().status().stopping);
  INFO("commutation: " << servo::name(daemon.cycle().status().mode));
  CHECK(daemon.cycle().status().mode == service);
  // The client that lapsed must take control again.
  REQUIRE(publisher.submit_command(authored(C::ENABLE, 5, 5)));
  serve();
  CHECK_THAT(acks(sink).find(5)->second.text, Catch::StartsWith("rejected: not_in_control"));
}
