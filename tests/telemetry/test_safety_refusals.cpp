// The journal's record of refused stops (daemon/telemetry/safety_refusals.hpp):
// each kept refusal is one line with time, kind, client, code and reason; at
// most kLinesPerSecond per wall-clock second, the rest said in one line each
// second once it is over.
#include <catch2/catch.hpp>

#include "daemon/telemetry/safety_refusals.hpp"

using clm::servo::CommandKind;
using clm::servo::CommandResult;
using clm::telemetry::SafetyRefusalLog;

namespace {
// 2026-11-27T09:00:00Z [µs since the UNIX epoch]
constexpr std::int64_t kSecond0 = 1795770000ll * 1000000;
}  // namespace

TEST_CASE("a refused stop is one line with its time, kind, client, code and reason", "[telemetry][refusals]") {
  CHECK(clm::telemetry::utc_time_text(kSecond0 + 123456) == "2026-11-27T09:00:00.123Z");
  SafetyRefusalLog log;
  log.record(kSecond0 + 250000, CommandKind::kQuickStop, 42, 7, CommandResult::kRejectedOtherAxis,
             "for axis 'x', this daemon drives axis 'axis0'");
  const auto lines = log.take_lines(kSecond0 + 300000);
  REQUIRE(lines.size() == 1);
  CHECK(lines[0] == "refused quick_stop at 2026-11-27T09:00:00.250Z from client 42 (sequence 7): code " +
                        std::to_string(static_cast<int>(CommandResult::kRejectedOtherAxis)) +
                        ", for axis 'x', this daemon drives axis 'axis0'");
  CHECK(log.take_lines(kSecond0 + 400000).empty());
}

TEST_CASE("a flood of refusals: 5 lines a second, the rest counted once each second is over",
          "[telemetry][refusals]") {
  SafetyRefusalLog log;
  // 1000 refusals in each of two seconds, taken every 100 ms as the monitor does.
  std::size_t kept = 0;
  std::int64_t suppressed = 0;
  for (int ms = 0; ms < 2500; ms += 100) {
    if (ms < 2000) {
      for (int k = 0; k < 100; ++k) {
        log.record(kSecond0 + ms * 1000 + k * 1000, CommandKind::kStop, 1, ms * 100 + k,
                   CommandResult::kRejectedOtherAxis, "other axis");
      }
    }
    for (const auto& line : log.take_lines(kSecond0 + (ms + 100) * 1000)) {
      if (line.rfind("refused stop", 0) == 0) {
        ++kept;
      } else {
        INFO(line);
        REQUIRE(line.find(" more refusals of safety commands suppressed") != std::string::npos);
        suppressed += std::stoll(line);
      }
    }
  }
  CHECK(kept == 2 * SafetyRefusalLog::kLinesPerSecond);
  CHECK(static_cast<std::int64_t>(kept) + suppressed == 2000);
  CHECK(log.recorded() == 2000);
}
