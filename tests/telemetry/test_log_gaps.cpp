// No silent loss in LCM logs: the reader finds every CLM_SERVO_STATE left out
// of a log (a gap in the cycle counter), the messages the daemon itself
// dropped (servo_status_t.telemetry_dropped), and tells a recorder's marked
// pause from a loss. Each log here is written with LcmLogWriter with known
// cycles left out; the expectations are those cycles.
#include <catch2/catch.hpp>

#include <set>

#include "support/temporary_directory.hpp"
#include "telemetry/telemetry_samples.hpp"
#include "tools/lcmlog/servo_log.hpp"

using namespace clm::telemetry;
using clm::lcmlog::CycleRange;

namespace {

/// What goes into a test log, in file order.
struct LogEntry {
  enum Kind { kState, kStatus, kResumed } kind = kState;
  std::int64_t cycle = 0;              ///< kState
  std::int64_t session = 1;            ///< kStatus
  std::int64_t telemetry_dropped = 0;  ///< kStatus
};

void write_entries(const std::string& path, const std::vector<LogEntry>& entries) {
  LcmLogWriter writer(path);
  for (const auto& entry : entries) {
    switch (entry.kind) {
      case LogEntry::kState:
        publish_message(writer, kStateChannel, to_message(clm::test::make_state(entry.cycle)), 0);
        break;
      case LogEntry::kStatus: {
        auto status = clm::test::make_status();
        status.session = entry.session;
        publish_message(writer, kStatusChannel, to_message(status, entry.telemetry_dropped), 0);
        break;
      }
      case LogEntry::kResumed:
        mark_recording_resumed(writer, 0, 0);
        break;
    }
  }
  writer.close();
}

/// States of cycles first, first + step, ... up to last, except those in `left_out`.
std::vector<LogEntry> states(std::int64_t first, std::int64_t last, std::int64_t step,
                             const std::set<std::int64_t>& left_out = {}) {
  std::vector<LogEntry> entries;
  for (std::int64_t c = first; c <= last; c += step) {
    if (left_out.count(c) == 0) entries.push_back({LogEntry::kState, c});
  }
  return entries;
}

std::set<std::int64_t> cycles_from_to(std::int64_t first, std::int64_t last) {
  std::set<std::int64_t> cycles;
  for (std::int64_t c = first; c <= last; ++c) cycles.insert(c);
  return cycles;
}

std::vector<LogEntry> operator+(std::vector<LogEntry> a, const std::vector<LogEntry>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

LogEntry status(std::int64_t telemetry_dropped, std::int64_t session = 1) {
  return {LogEntry::kStatus, 0, session, telemetry_dropped};
}

}  // namespace

TEST_CASE("A complete log has no gap", "[lcmlog][gaps]") {
  const clm::test::TemporaryDirectory directory("clm_log_gaps_none");
  const std::string log = directory.file("run.lcm");
  write_entries(log, std::vector<LogEntry>{status(4)} + states(1000, 2999, 1) + std::vector<LogEntry>{status(4)});
  const auto read = clm::lcmlog::read_servo_state_log(log);
  REQUIRE(read.states.size() == 2000);
  CHECK(read.gaps.cycles.missing == 0);
  CHECK(read.gaps.cycles.gaps == 0);
  CHECK(read.gaps.cycles.listed.empty());
  CHECK(read.gaps.cycles.out_of_order == 0);
  CHECK(read.gaps.statuses == 2);
  CHECK(read.gaps.daemon_dropped == 0);  // 4 before the log began: not the log's
  CHECK_FALSE(read.gaps.any());
  CHECK(clm::lcmlog::describe_gaps(log, read.gaps).empty());
}

TEST_CASE("States left out of a log are reported as exactly those cycles, counted", "[lcmlog][gaps]") {
  const clm::test::TemporaryDirectory directory("clm_log_gaps_ranges");
  const std::string log = directory.file("run.lcm");
  std::set<std::int64_t> left_out = cycles_from_to(200, 204);
  left_out.insert(100);
  for (const auto c : cycles_from_to(500, 509)) left_out.insert(c);
  write_entries(log, std::vector<LogEntry>{status(0)} + states(0, 999, 1, left_out));
  const auto read = clm::lcmlog::read_servo_state_log(log);
  CHECK(read.states.size() == 1000 - left_out.size());
  const auto& gaps = read.gaps.cycles;
  CHECK(gaps.step_cycles == 1);
  CHECK(gaps.missing == 16);
  CHECK(gaps.gaps == 3);
  CHECK(gaps.listed == std::vector<CycleRange>{{100, 100}, {200, 204}, {500, 509}});
  CHECK(gaps.out_of_order == 0);
  CHECK(read.gaps.any());
  CHECK(clm::lcmlog::describe_gaps(log, read.gaps) ==
        log + ": 16 CLM_SERVO_STATE messages missing in 3 gaps (cycles 100, 200..204, 500..509); the daemon "
              "counted 0 telemetry messages dropped (servo_status_t.telemetry_dropped over 1 status)");
}

TEST_CASE("Of many gaps the first five are listed and all are counted", "[lcmlog][gaps]") {
  const clm::test::TemporaryDirectory directory("clm_log_gaps_many");
  const std::string log = directory.file("run.lcm");
  std::set<std::int64_t> left_out;
  for (std::int64_t c = 10; c < 1000; c += 10) left_out.insert(c);  // 10, 20, ..., 990: 99 gaps
  write_entries(log, states(0, 999, 1, left_out));
  const auto read = clm::lcmlog::read_servo_state_log(log);
  const auto& gaps = read.gaps.cycles;
  CHECK(gaps.missing == 99);
  CHECK(gaps.gaps == 99);
  CHECK(gaps.listed == std::vector<CycleRange>{{10, 10}, {20, 20}, {30, 30}, {40, 40}, {50, 50}});
  CHECK(clm::lcmlog::describe_ranges(gaps) == "10, 20, 30, 40, 50, ... and 94 more gaps");
  CHECK(clm::lcmlog::describe_gaps(log, read.gaps) ==
        log + ": 99 CLM_SERVO_STATE messages missing in 99 gaps (cycles 10, 20, 30, 40, 50, ... and 94 more gaps)"
              "; the daemon's own drop count is unknown (no CLM_SERVO_STATUS in the log)");
}

TEST_CASE("With state_decimation the gaps are counted in published states", "[lcmlog][gaps]") {
  const clm::test::TemporaryDirectory directory("clm_log_gaps_decimated");
  const std::string log = directory.file("run.lcm");
  // Every 10th cycle published (state_decimation 10); 50 and 120..140 lost.
  write_entries(log, states(0, 990, 10, {50, 120, 130, 140}));
  const auto gaps = clm::lcmlog::read_servo_state_log(log).gaps.cycles;
  CHECK(gaps.step_cycles == 10);
  CHECK(gaps.missing == 4);
  CHECK(gaps.gaps == 2);
  CHECK(gaps.listed == std::vector<CycleRange>{{50, 50}, {120, 140}});
}

TEST_CASE("The growth of the daemon's telemetry_dropped over the log is reported, per daemon session",
          "[lcmlog][gaps]") {
  const clm::test::TemporaryDirectory directory("clm_log_gaps_daemon");
  const std::string log = directory.file("run.lcm");
  SECTION("one session: from the first status to the last") {
    write_entries(log, std::vector<LogEntry>{status(3)} + states(0, 99, 1) + std::vector<LogEntry>{status(3)} +
                           states(100, 199, 1) + std::vector<LogEntry>{status(10)} + states(200, 299, 1) +
                           std::vector<LogEntry>{status(15)});
    const auto read = clm::lcmlog::read_servo_state_log(log);
    CHECK(read.gaps.cycles.missing == 0);
    CHECK(read.gaps.statuses == 4);
    CHECK(read.gaps.daemon_dropped == 15 - 3);
    CHECK(read.gaps.any());
    CHECK(clm::lcmlog::describe_gaps(log, read.gaps) ==
          log + ": no CLM_SERVO_STATE message missing; the daemon counted 12 telemetry messages dropped "
                "(servo_status_t.telemetry_dropped over 4 statuses)");
  }
  SECTION("a daemon restarted within the log: its drops count from its start") {
    write_entries(log, std::vector<LogEntry>{status(3, 1)} + states(0, 99, 1) +
                           std::vector<LogEntry>{status(5, 1), status(4, 2)} + states(0, 99, 1) +
                           std::vector<LogEntry>{status(6, 2)});
    const auto read = clm::lcmlog::read_servo_state_log(log);
    CHECK(read.gaps.daemon_dropped == (5 - 3) + 6);
    CHECK(read.gaps.cycles.out_of_order == 1);  // cycle 0 after cycle 99
    CHECK(read.gaps.cycles.missing == 0);
  }
}

TEST_CASE("A step across a recording-resumed marker is a pause, any other a loss", "[lcmlog][gaps]") {
  const clm::test::TemporaryDirectory directory("clm_log_gaps_marked");
  const std::string log = directory.file("run.lcm");
  const LogEntry resumed{LogEntry::kResumed};
  write_entries(log, std::vector<LogEntry>{resumed} + states(0, 99, 1) + std::vector<LogEntry>{resumed} +
                         states(500, 599, 1, {550}) + std::vector<LogEntry>{resumed} + states(900, 999, 1));
  const auto gaps = clm::lcmlog::read_servo_state_log(log).gaps.cycles;
  CHECK(gaps.pauses == 2);
  CHECK(gaps.step_cycles == 1);
  CHECK(gaps.missing == 1);
  CHECK(gaps.listed == std::vector<CycleRange>{{550, 550}});
}

TEST_CASE("A log without a CLM_SERVO_STATE message is refused, naming the file", "[lcmlog][gaps]") {
  const clm::test::TemporaryDirectory directory("clm_log_gaps_empty");
  const std::string log = directory.file("run.lcm");
  write_entries(log, {});
  CHECK_THROWS_WITH(clm::lcmlog::read_servo_state_log(log), log + ": no CLM_SERVO_STATE message (an empty file)");
  write_entries(log, {status(0), status(0), LogEntry{LogEntry::kResumed}});
  CHECK_THROWS_WITH(clm::lcmlog::read_servo_state_log(log), log + ": no CLM_SERVO_STATE message among 3 events");
}

TEST_CASE("find_cycle_gaps examines every step but the marked ones", "[lcmlog][gaps]") {
  const std::vector<std::int64_t> cycles = {10, 11, 13, 14, 20, 21, 21, 40, 41};
  const std::vector<std::size_t> resumed = {7};  // 21 → 40 is a pause
  const auto gaps = clm::lcmlog::find_cycle_gaps(cycles, 1, resumed);
  CHECK(gaps.missing == 1 + 5);
  CHECK(gaps.gaps == 2);
  CHECK(gaps.listed == std::vector<CycleRange>{{12, 12}, {15, 19}});
  CHECK(gaps.out_of_order == 1);
  CHECK(gaps.pauses == 1);
  CHECK(clm::lcmlog::published_step_cycles(cycles, resumed) == 1);
  CHECK(clm::lcmlog::published_step_cycles(std::vector<std::int64_t>{7}) == 1);
}
