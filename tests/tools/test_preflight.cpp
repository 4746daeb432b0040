// The checks of `clm commission --live` before its first experiment
// (tools/commission/preflight.hpp), on a daemon's status and state made here:
// each wrong setting gives one refusal naming it and the fix; a good one none.
#include <catch2/catch.hpp>
#include <cstdio>

#include <filesystem>
#include <fstream>

#include "support/temporary_directory.hpp"
#include "tools/commission/commission.hpp"
#include "tools/commission/preflight.hpp"

using namespace clm;

namespace {

struct Preflight {
  test::TemporaryDirectory directory{"clm-preflight"};
  commission::Options options;
  servod::ServodConfig config;
  commission::DaemonView daemon;

  Preflight() {
    options.config_path = std::string(CLM_SOURCE_DIR) + "/config/servod.yaml";
    options.out_dir = directory.file("out");
    options.program_path = std::string(CLM_SOURCE_DIR) + "/tests/support/one_stroke_program.yaml";
    options.experiment_program_path = options.program_path;
    options.validation_program_path = "none";
    options.live = true;
    config = servod::load_servod_config(options.config_path);
    config.commands.file_directories = {std::filesystem::canonical(directory.file("")).string()};
    // A healthy daemon of this configuration: 0.1 ms wake-up latency at most, no overrun.
    daemon.status = {};  // every field zero, as in a status of a fresh daemon
    daemon.status.axis = config.axis_name;
    daemon.status.motor_sha256 = config.motor_sha256;
    daemon.status.cycles = 10000;
    daemon.status.wakeup_latency_p99_s = 50e-6;
    daemon.status.wakeup_latency_max_s = 100e-6;
    clm_lcm::servo_state_t state{};
    state.coil_sets = static_cast<std::int8_t>(config.motor.coil_sets);
    state.drive_profile = static_cast<std::int8_t>(config.motor.drive_profile);
    daemon.state = state;
  }
  std::vector<std::string> run(std::int64_t available_bytes = 1ll << 40) {
    return commission::live_preflight(config, options, daemon, available_bytes);
  }
};

}  // namespace

TEST_CASE("preflight: a healthy daemon and fitting programs pass", "[commission][preflight]") {
  Preflight p;
  const auto refusals = p.run();
  INFO(commission::describe_refusals(refusals));
  CHECK(refusals.empty());
}

TEST_CASE("preflight: too little free space in --out is refused with the estimate", "[commission][preflight]") {
  Preflight p;
  // One-stroke program (4.6 s a run): 6 experiment runs and 2 x 6 law runs
  // at 1 kHz, each state at least its encoded CLM_SERVO_STATE.
  const auto programs = commission::planned_programs(p.options, p.config);
  int runs = 0;
  for (const auto& planned : programs) runs += planned.runs;
  CHECK(runs == 2 * p.config.motor.coil_sets + 2 * 6);
  const std::int64_t floor_bytes = static_cast<std::int64_t>(runs * 4.6 * 1000) * clm_lcm::servo_state_t{}.getEncodedSize();
  const std::int64_t estimate = commission::estimate_output_bytes(programs, p.config.servo.period_s);
  CHECK(estimate > floor_bytes);
  CHECK(estimate < 20 * floor_bytes + commission::kFixedOutputBytes);
  const auto refusals = p.run(estimate - 1);
  INFO(commission::describe_refusals(refusals));
  REQUIRE(refusals.size() == 1);
  CHECK_THAT(refusals[0], Catch::Contains("--out") && Catch::Contains("free") && Catch::Contains("Fix:"));
  CHECK(p.run(estimate).empty());
}

TEST_CASE("preflight: a program beyond the motion limits or the soft limits is refused by the daemon's rule",
          "[commission][preflight]") {
  Preflight p;
  const std::string fast = p.directory.file("fast.yaml");
  std::ofstream(fast) << "format: clm-servo-program\nformat_version: 1\nstart_m: 0.0\nsteps:\n"
                         "  - {target_m: 0.05, velocity_m_per_s: 2.0, acceleration_m_per_s2: 1.0, "
                         "jerk_m_per_s3: 100.0, dwell_s: 0.1}\n";
  p.options.program_path = fast;
  auto refusals = p.run();
  INFO(commission::describe_refusals(refusals));
  REQUIRE(refusals.size() == 1);
  CHECK_THAT(refusals[0], Catch::Contains("evaluation program " + fast) && Catch::Contains("velocity") &&
                              Catch::Contains("Fix:"));
  const std::string wide = p.directory.file("wide.yaml");
  std::ofstream(wide) << "format: clm-servo-program\nformat_version: 1\nstart_m: 0.0\nsteps:\n"
                         "  - {target_m: 0.3, velocity_m_per_s: 0.1, acceleration_m_per_s2: 1.0, "
                         "jerk_m_per_s3: 100.0, dwell_s: 0.1}\n";
  p.options.program_path = p.options.experiment_program_path;
  p.options.experiment_program_path = wide;
  refusals = p.run();
  INFO(commission::describe_refusals(refusals));
  REQUIRE(refusals.size() == 1);
  CHECK_THAT(refusals[0], Catch::Contains("experiment program " + wide) && Catch::Contains("soft limit"));
}

TEST_CASE("preflight: the force a program's acceleration takes beyond force_limit_N is refused",
          "[commission][preflight]") {
  Preflight p;
  // control.mass_kg (15.45 kg) x 1 m/s^2 = 15.45 N: a 10 N limit is below it.
  p.config.servo.force_limit_N = 10.0;
  const auto refusals = p.run();
  INFO(commission::describe_refusals(refusals));
  REQUIRE(refusals.size() == 2);  // the experiment and the evaluation program
  char force[64];
  std::snprintf(force, sizeof(force), "takes %g N at control.mass_kg %g kg", p.config.control_mass_kg,
                p.config.control_mass_kg);
  CHECK_THAT(refusals[0], Catch::Contains(force) && Catch::Contains("control.force_limit_N 10 N"));
}

TEST_CASE("preflight: another drive profile on the daemon is refused", "[commission][preflight]") {
  Preflight p;
  p.daemon.state->drive_profile = static_cast<std::int8_t>(DriveProfile::kPhaseCurrent);
  const auto refusals = p.run();
  INFO(commission::describe_refusals(refusals));
  REQUIRE(refusals.size() == 1);
  CHECK_THAT(refusals[0], Catch::Contains("phase_current") && Catch::Contains("magnitude_phase") &&
                              Catch::Contains("Fix:"));
}

TEST_CASE("preflight: a watchdog below period + 3 x the measured max latency, and an overrun limit that would "
          "trip, are refused with the figures and the fix", "[commission][preflight]") {
  Preflight p;
  p.config.motor.drive_watchdog_timeout_s = 0.005;  // a real drive's (config/motor-real.yaml)
  p.daemon.status.wakeup_latency_max_s = 2e-3;  // needs 1 + 3 x 2 = 7 ms
  p.daemon.status.overruns = 1000;              // a tenth of the cycles
  p.config.servo.overrun_limit = 3;             // 1e-3 per cycle: many trips in the commissioning
  const auto refusals = p.run();
  INFO(commission::describe_refusals(refusals));
  REQUIRE(refusals.size() == 2);
  CHECK_THAT(refusals[0], Catch::Contains("drive.watchdog_timeout_s 5 ms") && Catch::Contains("max 2 ms") &&
                              Catch::Contains("at least 7 ms") && Catch::Contains(p.config.motor_file));
  CHECK_THAT(refusals[1], Catch::Contains("faults.overrun_limit 3") && Catch::Contains("1000 overruns in 10000"));
  const std::string line = commission::describe_refusals(refusals);
  CHECK_THAT(line, Catch::StartsWith("live commissioning refused before the first experiment (2 problems): 1) "));
  CHECK_THAT(line, Catch::Contains("; 2) faults.overrun_limit 3"));
}

TEST_CASE("preflight: --out outside the file directories and another motor are both said", "[commission][preflight]") {
  Preflight p;
  p.options.out_dir = "/";
  p.daemon.status.motor_sha256 = std::string(64, '0');
  const auto refusals = p.run();
  INFO(commission::describe_refusals(refusals));
  REQUIRE(refusals.size() == 2);
  CHECK_THAT(refusals[0], Catch::StartsWith("--out '/'") && Catch::Contains("outside"));
  CHECK_THAT(refusals[1], Catch::Contains("is not the motor axis"));
}
