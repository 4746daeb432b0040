// Run-time parameters (docs/servod.md "Run-time parameters"): get answers the
// values the cycle uses; set is checked as the configuration is, applied by
// the cycle at standstill only, and what moves are checked against follows.
// Expectations come from the configuration file and control::tune_pid, not
// from the daemon's own answers.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>

#include "daemon/servod/parameters.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using Kind = servo::CommandKind;

namespace {

servo::Command get(const std::string& key, std::int64_t sequence = 0) {
  servo::Command command;
  command.kind = Kind::kGetParameter;
  command.sequence = sequence;
  command.parameter.assign(key);
  return command;
}

servo::Command set(const std::string& key, double value, std::int64_t sequence = 0) {
  servo::Command command = get(key, sequence);
  command.kind = Kind::kSetParameter;
  command.value = value;
  return command;
}

/// Submits a set and runs a cycle: the cycle's reply (or the daemon's refusal).
servod::CommandReply set_and_apply(servod::ServoDaemon& daemon, const std::string& key, double value) {
  static std::int64_t sequence = 1000;
  const auto submitted = daemon.submit(set(key, value, ++sequence));
  if (!submitted.accepted()) return submitted;
  daemon.run_cycles(1);
  for (const auto& reply : daemon.take_replies()) {
    if (reply.sequence == sequence) return reply;
  }
  FAIL("no reply to set " << key);
  return {};
}

servo::Command move_to(double target_m, double velocity_m_per_s) {
  servo::Command move;
  move.kind = Kind::kMoveTo;
  move.target_m = target_m;
  move.limits = {velocity_m_per_s, 1.0, 1000.0};
  return move;
}

}  // namespace

TEST_CASE("get answers every run-time parameter with the value of the configuration", "[daemon][parameters]") {
  const auto config = test::virtual_config();
  servod::WiredAxis axis(config);
  auto& daemon = axis.daemon;
  const auto answer = [&](const std::string& key) { return daemon.submit(get(key)).text(); };
  CHECK(answer("control.bandwidth_hz") == "control.bandwidth_hz = 40 Hz");  // config/servod.yaml
  CHECK(answer("control.mass_kg") == "control.mass_kg = 15.45 kg");  // config/servod.yaml
  CHECK(answer("motion.velocity_m_per_s") == "motion.velocity_m_per_s = 0.5 m/s");
  CHECK(answer("motion.quick_stop_deceleration_m_per_s2") == "motion.quick_stop_deceleration_m_per_s2 = 20 m/s^2");
  CHECK(answer("control.force_limit_N") == "control.force_limit_N = 600 N");
  CHECK(answer("control.following_error_limit_m") == "control.following_error_limit_m = 0.002 m");
  const auto unknown = daemon.submit(get("control.soft_limit_max_m"));
  CHECK_FALSE(unknown.accepted());
  CHECK(unknown.text() == "rejected: unknown parameter 'control.soft_limit_max_m' (docs/servod.md)");
  // Every key of the table is a key of the configuration's sections.
  for (const auto& parameter : servod::runtime_parameters()) {
    const std::string key = parameter.key;
    CHECK((key.rfind("control.", 0) == 0 || key.rfind("motion.", 0) == 0));
    CHECK(daemon.submit(get(key)).accepted());
  }
}

TEST_CASE("set is applied by the cycle at standstill, and moves are checked against the new limits",
          "[daemon][parameters]") {
  const auto config = test::virtual_config();
  servod::WiredAxis axis(config);
  auto& daemon = axis.daemon;
  daemon.run_cycles(10);
  test::command(daemon, Kind::kEnable, 10);

  // A slower velocity limit: a move at the old limit is refused, naming the new one.
  REQUIRE(set_and_apply(daemon, "motion.velocity_m_per_s", 0.2).accepted());
  CHECK(daemon.cycle().settings().motion_limits.velocity_m_per_s == 0.2);
  CHECK(daemon.submit(get("motion.velocity_m_per_s")).text() == "motion.velocity_m_per_s = 0.2 m/s");
  const auto fast = daemon.submit(move_to(0.05, 0.3));
  CHECK_FALSE(fast.accepted());
  CHECK(fast.text().find("0.2") != std::string::npos);
  CHECK(daemon.submit(move_to(0.05, 0.2)).accepted());

  // While the move runs, no change; the refusal says why.
  daemon.run_cycles(20);
  const auto busy = daemon.submit(set("control.bandwidth_hz", 20.0, 7));
  CHECK_FALSE(busy.accepted());
  CHECK(busy.text() == "rejected: a program is running");
  daemon.run_until_idle(20000);

  // The loop's gains are those tune_pid gives for the configured mass.
  REQUIRE(set_and_apply(daemon, "control.bandwidth_hz", 20.0).accepted());
  const control::PidGains expected = control::tune_pid(config.control_mass_kg, 20.0);
  CHECK(daemon.cycle().settings().pid.proportional_N_per_m == expected.proportional_N_per_m);
  CHECK(daemon.cycle().settings().pid.derivative_N_s_per_m == expected.derivative_N_s_per_m);
  daemon.run_cycles(200);
  CHECK(daemon.cycle().status().state == servo::ServoState::kEnabled);  // no bump at rest
  REQUIRE(daemon.submit(move_to(-0.02, 0.1)).accepted());
  daemon.run_until_idle(20000);
  daemon.run_cycles(500);
  CHECK(std::abs(axis.simulated_motor()->truth().position_m - (-0.02)) < 1e-5);
}

TEST_CASE("set refuses what the configuration refuses, and a move while a change is on its way",
          "[daemon][parameters]") {
  servod::WiredAxis axis(test::virtual_config());
  auto& daemon = axis.daemon;
  daemon.run_cycles(10);
  const auto refused = [&](const std::string& key, double value) {
    const auto reply = daemon.submit(set(key, value));
    CHECK_FALSE(reply.accepted());
    return reply.text();
  };
  CHECK(refused("control.force_limit_N", 900.0) ==
        "rejected: control.force_limit_N: expected a number in [1, 819] N, got 900");
  CHECK(refused("control.bandwidth_hz", 200.0) ==
        "rejected: control.bandwidth_hz: expected a number in [1, 166.66666666666666] Hz, got 200");  // 1 kHz / 6
  CHECK(refused("control.mass_kg", 20.0) ==
        "rejected: control.mass_kg is fixed at start-up (the configuration file)");
  CHECK(refused("motion.bogus", 1.0) == "rejected: unknown parameter 'motion.bogus' (clm ctl get lists them)");
  // Below the stop's 10 m/s^2: ServoSettings::validate's cross check.
  CHECK(refused("motion.quick_stop_deceleration_m_per_s2", 5.0).find("must not be below the stop's") !=
        std::string::npos);
  CHECK(daemon.cycle().settings().quick_stop_limits.deceleration_m_per_s2 == 20.0);  // nothing changed

  test::command(daemon, Kind::kEnable, 10);
  REQUIRE(daemon.submit(set("control.following_error_limit_m", 0.001, 50)).accepted());  // queued, not yet applied
  const auto move = daemon.submit(move_to(0.01, 0.1));
  CHECK_FALSE(move.accepted());
  CHECK(move.text() == "rejected: a parameter change is being applied; send the command again");
  const auto second = daemon.submit(set("control.force_limit_N", 500.0, 51));
  CHECK(second.text() == "rejected: a parameter change is being applied; send the command again");
  daemon.run_cycles(1);
  (void)daemon.take_replies();
  CHECK(daemon.cycle().settings().following_error_limit_m == 0.001);
  CHECK(daemon.submit(move_to(0.01, 0.1)).accepted());
}

TEST_CASE("a bandwidth whose PID gains overflow with the configured mass is refused, nothing changed",
          "[daemon][parameters]") {
  const servod::ServodConfig config = test::virtual_config();
  // k_i ≈ 0.111·m·(2π·f)³ (tune_pid): for 1e301 kg about 2e306 N/(m*s) at 20 Hz, above 1.8e308 at 160 Hz.
  const servod::RuntimeValues values{config.servo.tuning(), 1e301, 20.0};
  const control::PlantModel plant{.mass_kg = 1e301};
  const auto change = servod::change_parameter(values, config.servo, 1000.0, plant, "control.bandwidth_hz", 160.0);
  CHECK_FALSE(change.values.has_value());
  CHECK(change.refusal.rfind("control.bandwidth_hz = 160: tune_pid: mass_kg 1e+301 kg at bandwidth_hz 160 Hz gives "
                             "non-finite gains",
                             0) == 0);
  CHECK(servod::change_parameter(values, config.servo, 1000.0, plant, "control.bandwidth_hz", 30.0).values.has_value());
}

TEST_CASE("a feedforward parameter set after a feedforward file is loaded takes the file's name out of the status",
          "[daemon][parameters]") {
  test::TemporaryDirectory dir("clm-daemon-parameters");
  auto config = test::virtual_config();
  config.commands.file_directories.push_back(std::filesystem::canonical(dir.path()).string());
  servod::WiredAxis axis(config);
  auto& daemon = axis.daemon;
  daemon.run_cycles(10);
  test::write_text(dir.file("ff.yaml"), "format: clm-servo-feedforward\nformat_version: 1\nmass_kg: 15.5\n"
                                        "viscous_N_s_per_m: 2.0\ncoulomb_N: 7.0\n");
  servo::Command load;
  load.kind = Kind::kLoadFeedforward;
  load.sequence = 60;
  load.path.assign(dir.file("ff.yaml"));
  const auto loaded = daemon.submit(load);
  INFO(loaded.text());
  REQUIRE(loaded.accepted());
  daemon.run_cycles(2);
  (void)daemon.take_replies();
  telemetry::LoadedFileText file;
  daemon.loaded_file(servod::LoadedFileSlot::kFeedforward, file);
  CHECK_FALSE(file.path.view().empty());
  CHECK(daemon.submit(get("control.feedforward.mass_kg")).text() == "control.feedforward.mass_kg = 15.5 kg");

  REQUIRE(set_and_apply(daemon, "control.feedforward.coulomb_N", 5.0).accepted());
  CHECK(daemon.cycle().settings().feedforward.coulomb_N == 5.0);
  CHECK(daemon.cycle().settings().feedforward.mass_kg == 15.5);  // the file's, kept
  daemon.loaded_file(servod::LoadedFileSlot::kFeedforward, file);
  CHECK(file.path.view().empty());
}

TEST_CASE("a bandwidth whose loop keeps less than the least margins on the described plant is refused, nothing changed",
          "[daemon][parameters]") {
  // The plant a motor file would describe: a 270 Hz mode, a 1.35 kHz current
  // loop and 0.27 ms of delays. At 130 Hz the rule's 45.6° lose the hold's
  // ωT/2 (23°) and the delays' 360·f·τ (13°): below 30°. At 40 Hz about 33° stay.
  auto config = test::virtual_config();
  config.plant = control::PlantModel{.mass_kg = config.control_mass_kg,
                                     .mode_frequency_Hz = 270.0,
                                     .mode_damping_ratio = 0.02,
                                     .current_loop_bandwidth_Hz = 1350.0,
                                     .delay_s = 2.7e-4};
  servod::WiredAxis axis(config);
  auto& daemon = axis.daemon;
  daemon.run_cycles(10);
  const auto refused = daemon.submit(set("control.bandwidth_hz", 130.0));
  CHECK_FALSE(refused.accepted());
  CHECK_THAT(refused.text(), Catch::StartsWith("rejected: control.bandwidth_hz = 130: the position loop would be "
                                               "unstable ("));
  CHECK_THAT(refused.text(), Catch::Contains("on the plant the motor file describes"));
  CHECK(daemon.submit(get("control.bandwidth_hz")).text() == "control.bandwidth_hz = 40 Hz");
  CHECK(daemon.cycle().settings().pid.proportional_N_per_m ==
        control::tune_pid(config.control_mass_kg, 40.0).proportional_N_per_m);
  CHECK(set_and_apply(daemon, "control.bandwidth_hz", 35.0).accepted());
}
