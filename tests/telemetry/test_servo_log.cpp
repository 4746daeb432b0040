// LCM logs: LcmLogWriter → read_servo_states → CSV, and damaged logs refused
// with the event number.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "support/temporary_directory.hpp"
#include "telemetry/telemetry_samples.hpp"
#include "tools/data/csv_table.hpp"
#include "tools/lcmlog/cmd_log2csv.hpp"
#include "tools/lcmlog/servo_log.hpp"

using namespace clm::telemetry;
namespace fs = std::filesystem;

namespace {

/// A log as the daemon writes it: a status first, then states, with an event
/// after every tenth state. Cycles 3, 7, 11, ... are in PGNN mode, the rest
/// in experiment mode. Returns the states and, for each, its event number.
struct WrittenLog {
  std::vector<clm::servo::CycleRecord> states;
  std::vector<std::int64_t> event_numbers;
  std::int64_t events = 0;
};

WrittenLog write_log(const std::string& path, int state_count, int coil_sets = 3) {
  WrittenLog log;
  LcmLogWriter writer(path);
  publish_message(writer, kStatusChannel, to_message(clm::test::make_status(), 0), 0);
  ++log.events;
  for (int i = 0; i < state_count; ++i) {
    auto state = clm::test::make_state(i, coil_sets);
    if (i % 4 == 3) {
      state.commutation = clm::servo::CommutationMode::kPgnn;
      state.coil_set = 0;
    }
    publish_message(writer, kStateChannel, to_message(state), state.utime);
    log.states.push_back(state);
    log.event_numbers.push_back(log.events++);
    if (i % 10 == 9) {
      ServoEventSample event;
      event.cycle = i;
      event.text.assign("ten more cycles");
      publish_message(writer, kEventChannel, to_message(event), 0);
      ++log.events;
    }
  }
  writer.close();
  return log;
}

std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::vector<unsigned char>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

/// Offsets of every event's sync word (0xEDA1DA01, big-endian) in a log.
std::vector<std::size_t> event_offsets(const std::vector<unsigned char>& bytes) {
  std::vector<std::size_t> offsets;
  for (std::size_t i = 0; i + 4 <= bytes.size(); ++i) {
    if (bytes[i] == 0xED && bytes[i + 1] == 0xA1 && bytes[i + 2] == 0xDA && bytes[i + 3] == 0x01) offsets.push_back(i);
  }
  return offsets;
}

/// Runs `clm log2csv ARGS` as the clm program would.
void log2csv(const std::string& arguments) {
  CLI::App app{"clm"};
  app.require_subcommand(1);
  clm::lcmlog::add_log2csv(app);
  app.parse("log2csv " + arguments, false);
}

}  // namespace

TEST_CASE("read_servo_states gives back every state written, in order, with every field equal, skipping other channels",
          "[lcmlog]") {
  const clm::test::TemporaryDirectory directory("clm_lcmlog_roundtrip");
  const std::string path = directory.file("run.lcm");
  const auto written = write_log(path, 50);
  CHECK(written.events == 1 + 50 + 5);
  const auto states = clm::lcmlog::read_servo_states(path);
  REQUIRE(states.size() == written.states.size());
  for (std::size_t i = 0; i < states.size(); ++i) {
    INFO("state " << i);
    clm::test::check_state(written.states[i], states[i]);
  }
}

TEST_CASE("log2csv --format experiment writes the experiment-mode states in the calibrate/identify columns",
          "[lcmlog]") {
  const clm::test::TemporaryDirectory directory("clm_lcmlog_experiment");
  const std::string log = directory.file("run.lcm");
  const std::string csv = directory.file("experiment.csv");
  const auto written = write_log(log, 40);
  log2csv("--log " + log + " --output " + csv + " --format experiment");

  const auto table = clm::data::CsvTable::load(csv);
  std::vector<clm::servo::CycleRecord> expected;
  for (const auto& s : written.states) {
    if (s.commutation == clm::servo::CommutationMode::kExperiment) expected.push_back(s);
  }
  REQUIRE(expected.size() == 30);
  REQUIRE(table.rows() == expected.size());
  const auto t = table.numbers("t_s"), coil_set = table.numbers("coil_set"), delta = table.numbers("delta_rad"),
             magnitude = table.numbers("magnitude_N"), y = table.numbers("y_m"), fy = table.numbers("Fy_N"),
             fx = table.numbers("Fx_N"), tz = table.numbers("Tz_Nm"), ia = table.numbers("ia_A"),
             ib = table.numbers("ib_A");
  for (std::size_t r = 0; r < expected.size(); ++r) {
    INFO("row " << r);
    const auto& s = expected[r];
    const auto l = static_cast<std::size_t>(s.coil_set - 1);
    CHECK(t[r] == s.t_s);
    CHECK(coil_set[r] == s.coil_set);
    CHECK(delta[r] == s.delta_rad);
    CHECK(magnitude[r] == s.magnitude_N[l]);
    CHECK(y[r] == s.y_m);
    CHECK(fy[r] == s.Fy_N);
    CHECK(fx[r] == s.Fx_N);
    CHECK(tz[r] == s.Tz_Nm);
    CHECK(ia[r] == s.ia_A[l]);
    CHECK(ib[r] == s.ib_A[l]);
  }
}

TEST_CASE("experiment columns carry forces only when every experiment state measured one", "[lcmlog]") {
  std::vector<clm::servo::CycleRecord> states;
  for (int i = 0; i < 6; ++i) {
    auto state = clm::test::make_state(i);
    state.force_measured = false;  // an axis without a force sensor: the record carries zeros
    state.Fy_N = state.Fx_N = state.Tz_Nm = 0.0;
    states.push_back(state);
  }
  const auto columns = clm::lcmlog::experiment_columns(states);
  CHECK(columns.names == std::vector<std::string>{"t_s", "coil_set", "delta_rad", "magnitude_N", "y_m", "ia_A", "ib_A"});
  CHECK(columns.rows() == states.size());
  // Some measured and some not: the force columns would hold zeros for forces.
  states[2].force_measured = true;
  CHECK_THROWS_WITH(clm::lcmlog::experiment_columns(states),
                    Catch::StartsWith("5 of 6 states in experiment mode carry no force measurement"));
}

TEST_CASE("log2csv --format feedforward writes t_s, r_m, F_star_N of every state", "[lcmlog]") {
  const clm::test::TemporaryDirectory directory("clm_lcmlog_feedforward");
  const std::string log = directory.file("run.lcm");
  const std::string csv = directory.file("ff.csv");
  const auto written = write_log(log, 25);
  log2csv("--log " + log + " --output " + csv + " --format feedforward");
  const auto table = clm::data::CsvTable::load(csv);
  REQUIRE(table.rows() == 25);
  const auto t = table.numbers("t_s"), r = table.numbers("r_m"), f = table.numbers("F_star_N");
  for (std::size_t i = 0; i < 25; ++i) {
    CHECK(t[i] == written.states[i].t_s);
    CHECK(r[i] == written.states[i].r_m);
    CHECK(f[i] == written.states[i].F_star_N);
  }
  CHECK_FALSE(table.has("y_m"));
}

TEST_CASE("log2csv --format full writes every field, coil-set columns per coil set, utime exact", "[lcmlog]") {
  const clm::test::TemporaryDirectory directory("clm_lcmlog_full");
  const std::string log = directory.file("run.lcm");
  const std::string csv = directory.file("full.csv");
  const auto written = write_log(log, 12, 2);
  log2csv("--log " + log + " --output " + csv + " --format full");
  const auto table = clm::data::CsvTable::load(csv);
  REQUIRE(table.rows() == 12);
  for (const char* name : {"utime", "cycle", "t_s", "r_m", "r_dot_m_per_s", "r_ddot_m_per_s2", "y_m", "e_m",
                           "F_star_N", "u_fb_N", "u_ff_N", "Fy_star_N", "Fx_star_N", "Tz_star_Nm", "Fy_N", "Fx_N",
                           "Tz_Nm", "commutation", "coil_set", "delta_rad", "coil_sets", "magnitude_N_1",
                           "setpoint_delta_rad_1", "ia_A_1", "ib_A_1", "magnitude_N_2", "setpoint_delta_rad_2",
                           "ia_A_2", "ib_A_2", "damping_engaged", "current_square_sum_A2", "force_limited", "state",
                           "program_running", "program_time_s", "drive_profile"}) {
    INFO(name);
    CHECK(table.has(name));
  }
  CHECK_FALSE(table.has("magnitude_N_3"));
  const auto utime = table.numbers("utime"), e = table.numbers("e_m"), u_ff = table.numbers("u_ff_N"),
             tz_star = table.numbers("Tz_star_Nm"), setpoint2 = table.numbers("setpoint_delta_rad_2"),
             ib2 = table.numbers("ib_A_2"), damping = table.numbers("damping_engaged"),
             current = table.numbers("current_square_sum_A2"), mode = table.numbers("commutation"),
             limited = table.numbers("force_limited"), state = table.numbers("state"),
             running = table.numbers("program_running"), program_time = table.numbers("program_time_s");
  for (std::size_t i = 0; i < 12; ++i) {
    const auto& s = written.states[i];
    CHECK(static_cast<std::int64_t>(utime[i]) == s.utime);
    CHECK(e[i] == s.e_m);
    CHECK(u_ff[i] == s.u_ff_N);
    CHECK(tz_star[i] == s.Tz_star_Nm);
    CHECK(setpoint2[i] == s.setpoint_delta_rad[1]);
    CHECK(ib2[i] == s.ib_A[1]);
    CHECK(damping[i] == (s.damping_engaged ? 1.0 : 0.0));
    CHECK(current[i] == s.current_square_sum_A2);
    CHECK(mode[i] == static_cast<double>(s.commutation));
    CHECK(limited[i] == (s.force_limited ? 1.0 : 0.0));
    CHECK(state[i] == static_cast<double>(s.state));
    CHECK(running[i] == (s.program_running ? 1.0 : 0.0));
    CHECK(program_time[i] == s.program_time_s);
  }
}

TEST_CASE("A state whose payload does not decode is refused with the file and its event number", "[lcmlog]") {
  const clm::test::TemporaryDirectory directory("clm_lcmlog_corrupt");
  const std::string log = directory.file("run.lcm");
  const auto written = write_log(log, 30);
  auto bytes = read_bytes(log);
  const auto offsets = event_offsets(bytes);
  REQUIRE(offsets.size() == static_cast<std::size_t>(written.events));

  // Flip a byte of the type fingerprint of state 17 (the payload's first 8 bytes).
  const std::int64_t event = written.event_numbers[17];
  const std::size_t payload = offsets[static_cast<std::size_t>(event)] + 28 + std::string(kStateChannel).size();
  bytes[payload + 3] ^= 0x5A;
  write_bytes(log, bytes);
  const std::string expected = log + ": event " + std::to_string(event) + ": cannot decode CLM_SERVO_STATE";
  CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(log), expected);

  // log2csv: the same one line, and no output file.
  const std::string csv = directory.file("out.csv");
  CHECK_THROWS_WITH(log2csv("--log " + log + " --output " + csv + " --format full"), expected);
  CHECK_FALSE(fs::exists(csv));
}

TEST_CASE("Garbage, a damaged header and a truncated last event are refused with the event number", "[lcmlog]") {
  const clm::test::TemporaryDirectory directory("clm_lcmlog_garbage");
  const std::string log = directory.file("run.lcm");
  const auto written = write_log(log, 20);
  const auto original = read_bytes(log);
  const auto offsets = event_offsets(original);

  const auto prefix = [&](std::int64_t event) { return log + ": event " + std::to_string(event) + ": "; };
  SECTION("garbage between two events") {
    auto bytes = original;
    bytes.insert(bytes.begin() + static_cast<std::ptrdiff_t>(offsets[9]), {1, 2, 3, 4, 5, 6, 7});
    write_bytes(log, bytes);
    CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(log),
                      prefix(9) + "no LCM sync word at byte " + std::to_string(offsets[9]) +
                          " (corrupt log, or not an LCM log)");
  }
  SECTION("truncated in the middle of the last event") {
    auto bytes = original;
    bytes.resize(offsets.back() + 40);
    write_bytes(log, bytes);
    CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(log),
                      prefix(written.events - 1) + "truncated: the event at byte " + std::to_string(offsets.back()) +
                          " needs " + std::to_string(original.size() - offsets.back() - 28) +
                          " bytes after its header, the file has 12");
  }
  SECTION("truncated in an event header") {
    auto bytes = original;
    bytes.resize(offsets.back() + 10);
    write_bytes(log, bytes);
    CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(log),
                      prefix(written.events - 1) + "truncated: 10 bytes at byte " + std::to_string(offsets.back()) +
                          ", less than an event header");
  }
  SECTION("a damaged event header") {
    auto bytes = original;
    bytes[offsets[4] + 20] = 0xFF;  // channel length (after sync, event number, timestamp) made negative
    write_bytes(log, bytes);
    CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(log),
                      prefix(4) + "channel length -16777201 outside 1..999 (corrupt log)");
  }
  SECTION("a file that is not an LCM log") {
    write_bytes(log, {'t', '_', 's', ',', 'y', '_', 'm', '\n', '0', ',', '0', ',', '0', ',', '0', '\n', '1', ',', '1',
                      ',', '1', ',', '1', ',', '1', ',', '1', '\n'});
    CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(log),
                      prefix(0) + "no LCM sync word at byte 0 (corrupt log, or not an LCM log)");
  }
}

TEST_CASE("log2csv refuses a missing log, an unknown format and experiment data without experiment states",
          "[lcmlog]") {
  const clm::test::TemporaryDirectory directory("clm_lcmlog_errors");
  const std::string csv = directory.file("out.csv");
  CHECK_THROWS_AS(log2csv("--log " + directory.file("none.lcm") + " --output " + csv + " --format full"),
                  CLI::ValidationError);
  const std::string log = directory.file("run.lcm");
  {
    LcmLogWriter writer(log);
    auto state = clm::test::make_state(0);
    state.commutation = clm::servo::CommutationMode::kClassical;
    state.coil_set = 0;
    publish_message(writer, kStateChannel, to_message(state), 0);
    writer.close();
  }
  CHECK_THROWS_AS(log2csv("--log " + log + " --output " + csv + " --format csv"), CLI::ValidationError);
  CHECK_THROWS_WITH(log2csv("--log " + log + " --output " + csv + " --format experiment"),
                    log + ": no state in experiment mode (commutation 5 with a coil set) among 1 CLM_SERVO_STATE "
                          "messages");
  CHECK_FALSE(fs::exists(csv));
  CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(directory.file("none.lcm")),
                    Catch::StartsWith(directory.file("none.lcm") + ": cannot open"));
}

TEST_CASE("A state claiming more coil sets than a motor can have is refused with its event number", "[lcmlog]") {
  const clm::test::TemporaryDirectory directory("clm_lcmlog_coilsets");
  const std::string log = directory.file("run.lcm");
  {
    LcmLogWriter writer(log);
    publish_message(writer, kStateChannel, to_message(clm::test::make_state(0)), 0);
    auto message = to_message(clm::test::make_state(1));
    message.coil_sets = 9;
    for (auto* v : {&message.magnitude_N, &message.setpoint_delta_rad, &message.ia_A, &message.ib_A}) v->resize(9, 0.0);
    publish_message(writer, kStateChannel, message, 0);
    writer.close();
  }
  CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(log), log + ": event 1: CLM_SERVO_STATE: coil_sets 9 outside 0..8");
}

TEST_CASE("A state with an unknown commutation or state is refused with its event number", "[lcmlog]") {
  const clm::test::TemporaryDirectory directory("clm_lcmlog_unknown");
  const std::string log = directory.file("run.lcm");
  {
    LcmLogWriter writer(log);
    publish_message(writer, kStateChannel, to_message(clm::test::make_state(0)), 0);
    auto commutation = to_message(clm::test::make_state(1));
    commutation.commutation = 6;
    publish_message(writer, kStateChannel, commutation, 0);
    writer.close();
  }
  CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(log), log + ": event 1: CLM_SERVO_STATE: commutation 6 outside 0..5");
  {
    LcmLogWriter writer(log);
    auto state = to_message(clm::test::make_state(0));
    state.state = 3;
    publish_message(writer, kStateChannel, state, 0);
    writer.close();
  }
  CHECK_THROWS_WITH(clm::lcmlog::read_servo_states(log), log + ": event 0: CLM_SERVO_STATE: state 3 outside 0..2");
}
