// `clm calibrate`, `identify` and `ff-identify` read an LCM log of clm-servod
// as --data (recognised by its sync word, not its name): the same results as
// from the log's CSV conversion, bit for bit, and damaged or unsuitable logs
// refused with one line naming the log and the event.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>

#include "cli/cli_support.hpp"
#include "commutation/model_file.hpp"
#include "config/sha256.hpp"
#include "daemon/servod/feedforward_file.hpp"
#include "daemon/telemetry/telemetry.hpp"
#include "tools/lcmlog/servo_log.hpp"

using namespace clm;
using namespace clm::cli_test;
using clm::servod::FeedforwardFile;
using clm::servod::load_feedforward_file;
namespace fs = std::filesystem;

namespace {

const std::string kMotor = source_path("config/motor-sim.yaml");

void require_success(const std::vector<std::string>& args) {
  const ProcessResult result = run_clm(args);
  INFO("clm " << args.front() << ": " << result.err);
  REQUIRE(result.exit_code == 0);
}

/// Byte offset of every event of an LCM log, read here from the format
/// (sync, event number, timestamp, channel length, data length; big-endian),
/// independently of clm::lcmlog.
std::vector<std::uint64_t> event_offsets(const std::string& bytes) {
  const auto u32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(bytes[at + static_cast<std::size_t>(i)]);
    return v;
  };
  std::vector<std::uint64_t> offsets;
  std::size_t at = 0;
  while (at < bytes.size()) {
    REQUIRE(u32(at) == 0xEDA1DA01u);
    offsets.push_back(at);
    at += 28 + u32(at + 20) + u32(at + 24);
  }
  REQUIRE(at == bytes.size());
  return offsets;
}

/// Refusal as in test_refusals.cpp: status `exit_code` (2: bad input; 1: a
/// refusal at run time), one line, nothing written, an earlier output kept
/// byte for byte.
void check_refused(const std::vector<std::string>& args, const std::string& output, const std::string& expected,
                   int exit_code = 2) {
  const std::string directory = fs::path(output).parent_path().string();
  fs::remove(output);
  const auto before = listing(directory);
  const ProcessResult result = run_clm(args);
  INFO("stderr: " << result.err);
  CHECK(result.exit_code == exit_code);
  const auto lines = result.err_lines();
  REQUIRE(lines.size() == 1);
  CHECK(lines[0] == "clm " + args[0] + ": error: " + expected);
  CHECK(listing(directory) == before);
  const std::string previous = "an output of an earlier run\n";
  write_file(output, previous);
  CHECK(run_clm(args).exit_code == exit_code);
  CHECK(read_file(output) == previous);
  fs::remove(output);
}

/// The three subcommands reading `data`, writing into `dir`.
std::vector<std::vector<std::string>> readers(const TemporaryDirectory& dir, const std::string& data,
                                              const std::string& motor = kMotor) {
  return {{"calibrate", "--motor", motor, "--data", data, "--output", dir.file("calibration.yaml")},
          {"identify", "--motor", motor, "--data", data, "--output", dir.file("model.yaml"), "--model", "spline",
           "--no-selection"},
          {"ff-identify", "--data", data, "--output", dir.file("feedforward.yaml")}};
}

std::string output_of(const std::vector<std::string>& args) {
  return *(std::find(args.begin(), args.end(), "--output") + 1);
}

/// A log of `states` as LcmLogWriter writes it, one status message first so
/// that event numbers and state indices differ by one.
void write_states_log(const std::string& path, const std::vector<clm_lcm::servo_state_t>& states) {
  telemetry::LcmLogWriter writer(path);
  telemetry::publish_message(writer, telemetry::kStatusChannel, clm_lcm::servo_status_t{}, 0);
  for (const auto& state : states) telemetry::publish_message(writer, telemetry::kStateChannel, state, state.utime);
  writer.close();
}

/// The first `count` states of the experiments' log (the commissioning runs,
/// each after a recording-resumed marker; 0: all) without those at `left_out`
/// (indices), a status with telemetry_dropped `dropped_before` first and one
/// with `dropped_after` last. Returns the cycles left out.
std::vector<std::int64_t> write_experiments_without(const std::string& path, const std::set<std::size_t>& left_out,
                                                    std::size_t count = 0, std::int64_t dropped_before = 0,
                                                    std::int64_t dropped_after = 0) {
  static const lcmlog::ServoStateLog full = lcmlog::read_servo_state_log(experiment_files().lcm);
  REQUIRE(full.gaps.cycles.pauses == 5);  // six runs: 2 offsets × 3 coil sets
  REQUIRE(count <= full.states.size());
  telemetry::LcmLogWriter writer(path);
  clm_lcm::servo_status_t status{};
  status.telemetry_dropped = dropped_before;
  telemetry::publish_message(writer, telemetry::kStatusChannel, status, 0);
  std::vector<std::int64_t> cycles;
  for (std::size_t k = 0; k < (count == 0 ? full.states.size() : count); ++k) {
    const auto& state = full.states[k];
    if (left_out.count(k) != 0) {
      REQUIRE(state.cycle == full.states[k - 1].cycle + 1);  // inside a run
      cycles.push_back(state.cycle);
      continue;
    }
    if (k > 0 && state.cycle != full.states[k - 1].cycle + 1) telemetry::mark_recording_resumed(writer, 0, 0);
    telemetry::publish_message(writer, telemetry::kStateChannel, telemetry::to_message(state), state.utime);
  }
  status.telemetry_dropped = dropped_after;
  telemetry::publish_message(writer, telemetry::kStatusChannel, status, 0);
  writer.close();
  return cycles;
}

}  // namespace

TEST_CASE("calibrate, identify and ff-identify from a daemon LCM log equal the same from its log2csv conversion, "
          "bit for bit",
          "[cli][lcm]") {
  const ExperimentFiles& experiments = experiment_files();
  TemporaryDirectory dir;
  // Named .dat: the log is recognised by its first bytes, not by its extension.
  const std::string log = dir.file("experiments.dat");
  fs::create_symlink(experiments.lcm, log);
  const std::string experiment_csv = dir.file("experiments-from-log.csv");
  const std::string feedforward_csv = dir.file("feedforward-from-log.csv");
  require_success({"log2csv", "--log", log, "--output", experiment_csv, "--format", "experiment"});
  require_success({"log2csv", "--log", log, "--output", feedforward_csv, "--format", "feedforward"});

  {  // calibrate, paper and offset-robust
    for (const bool robust : {false, true}) {
      const std::string from_log = dir.file("calibration-log.yaml");
      const std::string from_csv = dir.file("calibration-csv.yaml");
      std::vector<std::string> a = {"calibrate", "--motor", kMotor, "--data", log, "--output", from_log};
      std::vector<std::string> b = {"calibrate", "--motor", kMotor, "--data", experiment_csv, "--output", from_csv};
      if (robust) {
        a.push_back("--robust");
        b.push_back("--robust");
      }
      require_success(a);
      require_success(b);
      CalibrationFile x = load_calibration_file(from_log);
      CalibrationFile y = load_calibration_file(from_csv);
      CHECK(x.data_sha256 == sha256_file(log));
      CHECK(y.data_sha256 == sha256_file(experiment_csv));
      REQUIRE(x.coil_sets.size() == 3);
      for (std::size_t l = 0; l < 3; ++l) {
        CHECK(x.coil_sets[l].estimate.motor_constant_N_per_A == y.coil_sets[l].estimate.motor_constant_N_per_A);
        CHECK(x.coil_sets[l].estimate.phase_offset_rad == y.coil_sets[l].estimate.phase_offset_rad);
        CHECK(x.coil_sets[l].gain_ratio == y.coil_sets[l].gain_ratio);
        CHECK(x.coil_sets[l].residual_rms_N == y.coil_sets[l].residual_rms_N);
      }
      // Everything but the provenance, as written (17 significant digits).
      x.data_sha256 = y.data_sha256 = x.created_utc = y.created_utc = "";
      CHECK(format_calibration_file(x) == format_calibration_file(y));
    }
  }
  {  // identify --model spline (one capacity: the selection is the same code either way)
    const std::string from_log = dir.file("model-log.yaml");
    const std::string from_csv = dir.file("model-csv.yaml");
    require_success(
        {"identify", "--motor", kMotor, "--data", log, "--output", from_log, "--model", "spline", "--no-selection"});
    require_success({"identify", "--motor", kMotor, "--data", experiment_csv, "--output", from_csv, "--model",
                     "spline", "--no-selection"});
    ModelFile x = load_model_file(from_log);
    ModelFile y = load_model_file(from_csv);
    x.provenance.data_sha256 = y.provenance.data_sha256 = x.provenance.created_utc = y.provenance.created_utc = "";
    CHECK(format_model_file(x) == format_model_file(y));
  }
  {  // ff-identify
    const std::string from_log = dir.file("feedforward-log.yaml");
    const std::string from_csv = dir.file("feedforward-csv.yaml");
    require_success({"ff-identify", "--data", log, "--output", from_log});
    require_success({"ff-identify", "--data", feedforward_csv, "--output", from_csv});
    const FeedforwardFile x = load_feedforward_file(from_log);
    const FeedforwardFile y = load_feedforward_file(from_csv);
    CHECK(x.parameters.mass_kg == y.parameters.mass_kg);
    CHECK(x.parameters.viscous_N_s_per_m == y.parameters.viscous_N_s_per_m);
    CHECK(x.parameters.coulomb_N == y.parameters.coulomb_N);
  }
}

TEST_CASE("a damaged LCM log is refused by calibrate, identify and ff-identify naming the event", "[cli][lcm]") {
  const ExperimentFiles& experiments = experiment_files();
  TemporaryDirectory dir;
  const std::string bytes = read_file(experiments.lcm);
  const auto offsets = event_offsets(bytes);
  REQUIRE(offsets.size() > 3000);
  const std::string log = dir.file("run.lcm");

  SECTION("a sync word overwritten") {
    std::string damaged = bytes;
    damaged.replace(offsets[1742], 4, "abcd");
    write_file(log, damaged);
    for (const auto& args : readers(dir, log)) {
      check_refused(args, output_of(args),
                    log + ": event 1742: no LCM sync word at byte " + std::to_string(offsets[1742]) +
                        " (corrupt log, or not an LCM log)");
    }
  }
  SECTION("cut inside an event") {
    write_file(log, bytes.substr(0, offsets[2900] + 40));
    const std::uint64_t needs = offsets[2901] - offsets[2900] - 28;
    for (const auto& args : readers(dir, log)) {
      check_refused(args, output_of(args),
                    log + ": event 2900: truncated: the event at byte " + std::to_string(offsets[2900]) + " needs " +
                        std::to_string(needs) + " bytes after its header, the file has 12");
    }
  }
}

TEST_CASE("a log's states are checked as CSV rows are, named by event: NaN, coil_set outside 1..L, no experiment",
          "[cli][lcm]") {
  const ExperimentFiles& experiments = experiment_files();
  TemporaryDirectory dir;
  const lcmlog::ServoStateLog full = lcmlog::read_servo_state_log(experiments.lcm);
  std::vector<clm_lcm::servo_state_t> states;
  for (std::size_t k = 0; k < 400; ++k) states.push_back(telemetry::to_message(full.states[k]));
  const std::string log = dir.file("run.lcm");

  SECTION("a NaN force") {
    states[57].Fy_N = std::numeric_limits<double>::quiet_NaN();
    write_states_log(log, states);  // event 0 is a status: state 57 is event 58
    for (const auto& args : readers(dir, log)) {
      if (args[0] == "ff-identify") continue;  // uses t_s, r_m, F_star_N only
      check_refused(args, output_of(args), log + ": event 58: column 'Fy_N': 'nan' is not a finite number");
    }
    states[57].Fy_N = 0.0;
    states[99].F_star_N = std::numeric_limits<double>::infinity();
    write_states_log(log, states);
    check_refused({"ff-identify", "--data", log, "--output", dir.file("ff.yaml")}, dir.file("ff.yaml"),
                  log + ": event 100: column 'F_star_N': 'inf' is not a finite number");
  }
  SECTION("coil set 3 of the default motor's log with the two-coil motor") {
    std::size_t first = 0;
    while (full.states[first].coil_set != 3) ++first;
    const std::string motor2 = source_path("config/motor-sim-2coil.yaml");
    for (const auto& args : readers(dir, experiments.lcm, motor2)) {
      if (args[0] == "ff-identify") continue;
      check_refused(args, output_of(args),
                    experiments.lcm + ": event " + std::to_string(full.events[first]) +
                        ": column 'coil_set': value 3 is not a coil set of this motor (1..2)");
    }
  }
  SECTION("no state in experiment mode") {
    for (auto& state : states) state.commutation = clm_lcm::servo_state_t::COMMUTATION_ORIGINAL;
    write_states_log(log, states);
    for (const auto& args : readers(dir, log)) {
      if (args[0] == "ff-identify") continue;  // closed-loop data in any mode
      check_refused(args, output_of(args),
                    log + ": no state in experiment mode (commutation 5 with a coil set) among 400 "
                          "CLM_SERVO_STATE messages");
    }
  }
}

TEST_CASE("log2csv, calibrate, identify and ff-identify warn of a log's missing states in one stderr line and "
          "still write",
          "[cli][lcm][gaps]") {
  TemporaryDirectory dir;
  const std::string log = dir.file("run.lcm");
  const auto cycles = write_experiments_without(log, {100, 300, 301, 302});
  REQUIRE(cycles.size() == 4);
  REQUIRE(cycles[3] == cycles[1] + 2);
  const std::string gaps = log + ": 4 CLM_SERVO_STATE messages missing in 2 gaps (cycles " + std::to_string(cycles[0]) +
                           ", " + std::to_string(cycles[1]) + ".." + std::to_string(cycles[3]) +
                           "); the daemon counted 0 telemetry messages dropped (servo_status_t.telemetry_dropped over "
                           "2 statuses)";
  auto commands = readers(dir, log);
  commands.push_back({"log2csv", "--log", log, "--output", dir.file("run.csv"), "--format", "full"});
  for (const auto& args : commands) {
    const ProcessResult result = run_clm(args);
    INFO("stderr: " << result.err);
    CHECK(result.exit_code == 0);
    // One line, the first; identify's progress lines follow it.
    const auto lines = result.err_lines();
    REQUIRE_FALSE(lines.empty());
    CHECK(lines.front() == "clm " + args[0] + ": warning: " + gaps);
    CHECK(std::count_if(lines.begin(), lines.end(), [](const std::string& l) { return l.rfind("clm ", 0) == 0; }) == 1);
    CHECK(fs::exists(output_of(args)));
  }
}

TEST_CASE("With --fail-on-gaps a log with missing states or daemon drops is refused: status 1, one line, nothing "
          "written",
          "[cli][lcm][gaps]") {
  TemporaryDirectory dir;
  const std::string log = dir.file("run.lcm");
  auto commands = readers(dir, log);
  commands.push_back({"log2csv", "--log", log, "--output", dir.file("run.csv"), "--format", "experiment"});
  for (auto& args : commands) args.push_back("--fail-on-gaps");

  // Refused before the states are used: a short stretch of the first run will do.
  SECTION("states missing") {
    const auto cycles = write_experiments_without(log, {200}, 600);
    REQUIRE(cycles.size() == 1);
    for (const auto& args : commands) {
      check_refused(args, output_of(args),
                    log + ": 1 CLM_SERVO_STATE message missing in 1 gap (cycles " + std::to_string(cycles[0]) +
                        "); the daemon counted 0 telemetry messages dropped (servo_status_t.telemetry_dropped over 2 "
                        "statuses) (--fail-on-gaps)",
                    1);
    }
  }
  SECTION("no state missing, but the daemon's drop counter grew") {
    write_experiments_without(log, {}, 600, 17, 17 + 3);
    for (const auto& args : commands) {
      check_refused(args, output_of(args),
                    log + ": no CLM_SERVO_STATE message missing; the daemon counted 3 telemetry messages dropped "
                          "(servo_status_t.telemetry_dropped over 2 statuses) (--fail-on-gaps)",
                    1);
    }
  }
  SECTION("a complete log passes") {
    write_experiments_without(log, {}, 600, 17, 17);
    for (const auto& args : commands) {
      if (args[0] != "log2csv") continue;  // the same reading as the others; their fits are tested above
      const ProcessResult result = run_clm(args);
      INFO("stderr: " << result.err);
      CHECK(result.exit_code == 0);
      CHECK(result.err.empty());
    }
  }
}

TEST_CASE("An empty log and a log without a state are bad input: status 2, one line naming the file, an earlier "
          "output kept",
          "[cli][lcm][gaps]") {
  TemporaryDirectory dir;
  const std::string log = dir.file("run.lcm");
  const std::string csv = dir.file("run.csv");
  const std::vector<std::string> log2csv = {"log2csv", "--log", log, "--output", csv, "--format", "full"};
  SECTION("0 bytes") {
    write_file(log, "");
    check_refused(log2csv, csv, log + ": no CLM_SERVO_STATE message (an empty file)");
  }
  SECTION("statuses only") {
    {
      telemetry::LcmLogWriter writer(log);
      telemetry::publish_message(writer, telemetry::kStatusChannel, clm_lcm::servo_status_t{}, 0);
      telemetry::publish_message(writer, telemetry::kStatusChannel, clm_lcm::servo_status_t{}, 0);
      writer.close();
    }
    auto commands = readers(dir, log);
    commands.push_back(log2csv);
    for (const auto& args : commands) {
      check_refused(args, output_of(args), log + ": no CLM_SERVO_STATE message among 2 events");
    }
  }
}
