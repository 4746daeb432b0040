// Acks and status that tell the truth (docs/servod.md "Files", docs/telemetry.md
// "Events"): loads on the loader thread, one at a time; refusals that never
// quote a file; move_to refused while disabled or faulted; the status's
// loaded files with SHA-256 and refusal count; an event for every change of
// state, law, commutation, loaded file, program start and end, and for a
// deferred law request superseded by a later one.
#include <catch2/catch.hpp>

#include <atomic>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "config/sha256.hpp"
#include "daemon/servod/file_loader.hpp"
#include "daemon/servod/telemetry_bridge.hpp"
#include "daemon/telemetry/memory_sink.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using Kind = servo::CommandKind;
using servo::CommutationMode;

namespace {

/// The default configuration, loading commands' files from `dir` too.
servod::ServodConfig config_loading_from(const test::TemporaryDirectory& dir) {
  auto config = test::virtual_config();
  config.commands.file_directories.push_back(std::filesystem::canonical(dir.path()).string());
  return config;
}

servo::Command load_model(const std::string& path, std::int64_t sequence) {
  servo::Command load;
  load.kind = Kind::kLoadModel;
  load.sequence = sequence;
  load.path.assign(path);
  return load;
}

servo::Command move_to(double target_m, std::int64_t sequence = 0) {
  servo::Command move;
  move.kind = Kind::kMoveTo;
  move.sequence = sequence;
  move.target_m = target_m;
  move.limits = {0.05, 1.0, 1000.0};
  return move;
}

/// Replies from take_replies until one for `sequence` comes (at most 5 s).
servod::CommandReply wait_for_reply(servod::ServoDaemon& daemon, std::int64_t sequence) {
  for (int k = 0; k < 5000; ++k) {
    for (const auto& reply : daemon.take_replies()) {
      if (reply.sequence == sequence) return reply;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  FAIL("no reply for sequence " << sequence);
  return {};
}

}  // namespace

TEST_CASE("the loader reads one file at a time off the caller's thread and is answered later", "[daemon][files]") {
  test::TemporaryDirectory dir("clm-daemon-loader");
  const auto files = test::write_truth_laws(dir, test::source_path("config/motor-sim.yaml"));
  servod::WiredAxis axis(config_loading_from(dir));
  servod::ServoDaemon& daemon = axis.daemon;
  servod::FileLoader loader;
  daemon.set_file_loader(&loader);
  daemon.run_cycles(10);

  // A job that holds the loader: any load meanwhile is refused, naming it.
  std::atomic<bool> release{false};
  REQUIRE(loader.start("/somewhere/slow.yaml", [&] {
            while (!release.load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
          }).empty());
  auto busy = daemon.submit(load_model(files.pgnn, 1));
  CHECK_FALSE(busy.accepted());
  CHECK_FALSE(busy.answered_later());
  CHECK(busy.text() == "rejected: busy loading /somewhere/slow.yaml");
  release = true;
  REQUIRE(loader.wait_idle(5.0));

  // Now it loads: the immediate reply is no answer, the answer comes later.
  const auto later = daemon.submit(load_model(files.pgnn, 2));
  CHECK(later.accepted());
  CHECK(later.answered_later());
  const auto answer = wait_for_reply(daemon, 2);
  CHECK(answer.accepted());
  CHECK(answer.text() == "loaded; swapped in at the next standstill");

  // The status names the file (canonical) and its SHA-256 once the cycle uses it.
  daemon.run_cycles(2);
  daemon.take_replies();
  telemetry::LoadedFileText file;
  daemon.loaded_file(servod::LoadedFileSlot::kPgnnModel, file);
  CHECK(file.path.view() == std::filesystem::canonical(files.pgnn).string());
  CHECK(file.sha256.view() == sha256_file(files.pgnn));
  daemon.set_file_loader(nullptr);
}

TEST_CASE("a refused file is named with its line and key, never quoted, the whole message goes to the log",
          "[daemon][files]") {
  test::TemporaryDirectory dir("clm-daemon-secret");
  const std::string secret = dir.file("secret.yaml");
  test::write_text(secret, "kind: SECRET\nformat: clm-servo-model\nformat_version: 1\n");
  std::filesystem::permissions(secret, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  servod::WiredAxis axis(config_loading_from(dir));
  servod::ServoDaemon& daemon = axis.daemon;
  std::vector<std::string> log;
  daemon.set_log([&](const std::string& line) { log.push_back(line); });

  const auto reply = daemon.submit(load_model(secret, 1));
  CHECK_FALSE(reply.accepted());
  CHECK(reply.text() == "rejected: load_model: invalid model file (line 1, key kind): '" + secret + "'");
  CHECK(reply.text().find("SECRET") == std::string::npos);
  REQUIRE(log.size() == 1);
  CHECK_THAT(log[0], Catch::Contains("got 'SECRET'") && Catch::StartsWith("refused model file '" + secret + "'"));

  // Outside the configured directories, and over the size limit: the rule and the path.
  const auto outside = daemon.submit(load_model(test::source_path("README.md"), 2));
  CHECK(outside.text() == "rejected: load_model: outside the directories commands may load from "
                        "(commands.file_directories): '" + test::source_path("README.md") + "'");
  servo::Command program;
  program.kind = Kind::kRunProgram;
  program.program.assign(secret);
  test::command(daemon, Kind::kEnable, 5);
  const auto not_a_program = daemon.submit(program);
  CHECK(not_a_program.text().find("SECRET") == std::string::npos);
  CHECK_THAT(not_a_program.text(), Catch::StartsWith("rejected: run_program: invalid program file"));
  CHECK(daemon.commands_refused() == 3);
}

TEST_CASE("move_to while disabled or faulted is refused with the reason, and counted", "[daemon][commands]") {
  servod::WiredAxis axis(test::virtual_config());
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(10);
  auto reply = daemon.submit(move_to(0.01, 1));
  CHECK_FALSE(reply.accepted());
  CHECK(reply.text() == "rejected: the axis is disabled, enable first");
  CHECK(daemon.commands_refused() == 1);

  test::command(daemon, Kind::kEnable, 20);
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  axis.in_process_bus()->injection().drop_drive_frames = 1000;
  test::run_until_fault(daemon, 1000);
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kFault);
  reply = daemon.submit(move_to(0.01, 2));
  CHECK_FALSE(reply.accepted());
  CHECK(reply.text() == "rejected: a fault is latched, clear it first");
  CHECK(daemon.commands_refused() == 2);
}

TEST_CASE("a posted move the cycle does not start is answered with the cycle's reason, never only counted",
          "[daemon][commands]") {
  servod::WiredAxis axis(test::virtual_config());
  servod::ServoDaemon& daemon = axis.daemon;
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 20);
  REQUIRE(daemon.cycle().status().state == servo::ServoState::kEnabled);
  (void)daemon.take_replies();
  const auto dropped_before = daemon.cycle().status().counters.programs_rejected;
  const auto refused_before = daemon.commands_refused();

  // Decided while enabled; a disable latched before the next cycle: the
  // cycle, which obeys the disable first, cannot start the move.
  const auto reply = daemon.submit(move_to(0.03, 7));
  REQUIRE(reply.accepted());
  REQUIRE(reply.answered_later());
  daemon.request_safety(Kind::kDisable);
  const servod::CommandReply answer = test::cycle_answer(daemon, 7);
  CHECK_FALSE(answer.accepted());
  CHECK(answer.result == servo::CommandResult::kRejectedDisabled);
  CHECK(answer.text() == "rejected: the axis is disabled, enable first");
  CHECK(daemon.cycle().status().counters.programs_rejected == dropped_before + 1);
  CHECK(daemon.commands_refused() == refused_before + 1);
  CHECK_FALSE(daemon.cycle().record().program_running);

  // Enabled again, the same move runs, and its answer says so.
  test::command(daemon, Kind::kEnable, 20);
  (void)daemon.take_replies();
  REQUIRE(daemon.submit(move_to(0.03, 8)).answered_later());
  CHECK(test::cycle_answer(daemon, 8).text() == "program posted");
  CHECK(daemon.cycle().record().program_running);
}

TEST_CASE("every change of state, commutation, law, file and program, and a superseded request, is an event",
          "[daemon][events]") {
  test::TemporaryDirectory dir("clm-daemon-events");
  const auto files = test::write_truth_laws(dir, test::source_path("config/motor-sim.yaml"));
  auto config = test::config_with_laws(files, CommutationMode::kOriginal);
  config.commands.file_directories.push_back(std::filesystem::canonical(dir.path()).string());
  servod::WiredAxis axis(config);
  servod::ServoDaemon& daemon = axis.daemon;
  telemetry::MemorySink sink;
  servod::TelemetryBridge bridge(sink, daemon, 1000);
  daemon.set_observer(&bridge);
  daemon.run_cycles(10);
  const auto events = [&] { return sink.decode<clm_lcm::servo_event_t>(telemetry::kEventChannel); };
  const auto count = [&](servod::EventCode code) {
    int n = 0;
    for (const auto& event : events()) n += event.code == static_cast<std::int16_t>(code);
    return n;
  };
  CHECK(events().empty());  // what the daemon started with is no change

  test::command(daemon, Kind::kEnable, 20);
  REQUIRE(events().size() == 1);
  CHECK(events()[0].text == "state enabled, fault 0: none");

  // A move: program start; two law requests while it runs: the first is
  // deferred, then superseded by the second.
  daemon.take_replies();
  REQUIRE(daemon.submit(move_to(0.03)).accepted());
  daemon.run_cycles(200);
  CHECK(count(servod::EventCode::kProgramStarted) == 1);
  const auto posted = daemon.take_replies();  // the cycle's answer once it took the move
  REQUIRE(posted.size() == 1);
  CHECK(posted[0].text() == "program posted");
  servo::Command pgnn;
  pgnn.kind = Kind::kSetCommutation;
  pgnn.commutation = CommutationMode::kPgnn;
  pgnn.sequence = 41;
  REQUIRE(daemon.submit(pgnn).accepted());
  daemon.run_cycles(1);
  const auto first = daemon.take_replies();
  REQUIRE(first.size() == 1);
  CHECK(first[0].text() == servo::describe(servo::CommandResult::kDeferred));
  servo::Command spline = pgnn;
  spline.commutation = CommutationMode::kSpline;
  spline.sequence = 42;
  REQUIRE(daemon.submit(spline).accepted());
  daemon.run_cycles(1);
  REQUIRE(count(servod::EventCode::kRequestSuperseded) == 1);
  for (const auto& event : events()) {
    if (event.code == static_cast<std::int16_t>(servod::EventCode::kRequestSuperseded)) {
      CHECK(event.text == "law request 41 superseded by request 42 before it took effect");
    }
  }
  daemon.run_until_idle(20000);
  daemon.run_cycles(500);
  CHECK(count(servod::EventCode::kProgramEnded) == 1);
  CHECK(count(servod::EventCode::kCommutationChanged) == 1);
  CHECK(daemon.cycle().status().mode == CommutationMode::kSpline);

  // A model loaded: the law swapped in and the status's file change, each once.
  test::write_text(dir.file("spline-2.yaml"),
                   format_model_file(test::truth_spline(sim::load_motor_parameters(test::source_path("config/motor-sim.yaml")))) +
                       "# another file\n");
  const auto loaded = daemon.submit(load_model(dir.file("spline-2.yaml"), 7));
  INFO(loaded.text());
  REQUIRE(loaded.accepted());
  daemon.run_cycles(5);
  daemon.take_replies();  // the command thread's pass: the status follows the law in use
  daemon.run_cycles(5);
  CHECK(count(servod::EventCode::kLawSwapped) == 1);
  CHECK(count(servod::EventCode::kFileLoaded) == 1);
  telemetry::LoadedFileText file;
  daemon.loaded_file(servod::LoadedFileSlot::kSplineModel, file);
  CHECK(file.sha256.view() == sha256_file(dir.file("spline-2.yaml")));
  daemon.set_observer(nullptr);
}

TEST_CASE("the force sensor lost in service is a warning event and a status field, and its return is an event too",
          "[daemon][events][force_sensor]") {
  servod::WiredAxis axis(test::virtual_config());
  servod::ServoDaemon& daemon = axis.daemon;
  telemetry::MemorySink sink;
  servod::TelemetryBridge bridge(sink, daemon, 1000);
  daemon.set_observer(&bridge);
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 20);
  const auto events = [&] { return sink.decode<clm_lcm::servo_event_t>(telemetry::kEventChannel); };
  const auto last_status = [&] { return sink.decode<clm_lcm::servo_status_t>(telemetry::kStatusChannel).back(); };
  daemon.run_cycles(100);
  CHECK(last_status().force_sensor == clm_lcm::servo_status_t::FORCE_SENSOR_OK);
  CHECK(last_status().force_sensor_warning == 0);

  const std::size_t before = events().size();
  axis.in_process_bus()->injection().drop_force_frames = 1000;
  daemon.run_cycles(200);
  auto now = events();
  REQUIRE(now.size() == before + 1);
  CHECK(now.back().code == static_cast<std::int16_t>(servod::EventCode::kForceSensorLost));
  CHECK(now.back().severity == 1);
  CHECK(now.back().text.find("102") != std::string::npos);
  const auto lost = last_status();
  CHECK(lost.force_sensor == clm_lcm::servo_status_t::FORCE_SENSOR_LOST);
  CHECK(lost.force_sensor_warning == static_cast<std::int16_t>(servo::Fault::kForceFrameMissing));
  CHECK(lost.force_sensor_losses == 1);
  CHECK(lost.state == clm_lcm::servo_status_t::STATE_ENABLED);
  CHECK(lost.fault == 0);

  axis.in_process_bus()->injection().drop_force_frames = 0;
  daemon.run_cycles(200);
  now = events();
  REQUIRE(now.size() == before + 2);
  CHECK(now.back().code == static_cast<std::int16_t>(servod::EventCode::kForceSensorBack));
  CHECK(last_status().force_sensor == clm_lcm::servo_status_t::FORCE_SENSOR_OK);
  CHECK(last_status().force_sensor_losses == 1);
  daemon.set_observer(nullptr);

  auto bare_config = test::virtual_config();
  bare_config.servo.protocol.force_sensor_node_id = can::kNoForceSensor;
  servod::WiredAxis bare(bare_config);
  telemetry::MemorySink bare_sink;
  servod::TelemetryBridge bare_bridge(bare_sink, bare.daemon, 1000);
  bare.daemon.set_observer(&bare_bridge);
  bare.daemon.run_cycles(200);
  const auto none = bare_sink.decode<clm_lcm::servo_status_t>(telemetry::kStatusChannel).back();
  CHECK(none.force_sensor == clm_lcm::servo_status_t::FORCE_SENSOR_NONE);
  CHECK(none.frames_missing == 0);
  bare.daemon.set_observer(nullptr);
}
