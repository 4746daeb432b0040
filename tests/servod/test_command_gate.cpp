// Command authority (daemon/servod/command_gate.hpp): axis, session, client,
// sequence, age and the control lease, each refusal counted by kind.
#include <catch2/catch.hpp>

#include "daemon/servod/command_gate.hpp"

using namespace clm::servod;

namespace {

constexpr std::int64_t kSession = 0x5eed;
constexpr std::int64_t kNow = 1'700'000'000'000'000;  // µs since the epoch
constexpr std::int64_t kSecond = 1'000'000;

CommandGate make_gate() { return CommandGate({"x-axis", kSession, 2.0, 30.0}); }

CommandOrigin from(std::int64_t client, std::int64_t sequence, std::int64_t utime_us = kNow) {
  return {"x-axis", kSession, client, sequence, utime_us};
}

}  // namespace

TEST_CASE("commands for another axis or session are refused and counted", "[gate]") {
  auto gate = make_gate();
  auto origin = from(1, 1);
  origin.axis = "y-axis";
  auto d = gate.admit(origin, CommandClass::kSafety, kNow);
  CHECK(d.refusal == GateRefusal::kOtherAxis);
  CHECK_THAT(d.reason, Catch::Contains("y-axis") && Catch::Contains("x-axis"));
  origin = from(1, 1);
  origin.session = kSession + 1;
  CHECK(gate.admit(origin, CommandClass::kSafety, kNow).refusal == GateRefusal::kOtherSession);
  CHECK(gate.count(GateRefusal::kOtherAxis) == 1);
  CHECK(gate.count(GateRefusal::kOtherSession) == 1);
  CHECK(gate.count(GateRefusal::kAdmitted) == 0);
}

TEST_CASE("a repeated or older sequence from the same client is refused; other clients count their own", "[gate]") {
  auto gate = make_gate();
  REQUIRE(gate.admit(from(7, 100), CommandClass::kSafety, kNow).admitted());
  CHECK(gate.admit(from(7, 100), CommandClass::kSafety, kNow).refusal == GateRefusal::kReplayed);
  CHECK(gate.admit(from(7, 99), CommandClass::kSafety, kNow).refusal == GateRefusal::kReplayed);
  CHECK(gate.admit(from(8, 1), CommandClass::kSafety, kNow).admitted());
  CHECK(gate.admit(from(7, 101), CommandClass::kSafety, kNow).admitted());
  CHECK(gate.count(GateRefusal::kReplayed) == 2);
  CHECK(gate.admit(from(0, 5), CommandClass::kSafety, kNow).refusal == GateRefusal::kNoClient);
}

TEST_CASE("commands older than max_age_s, or from the future, are refused", "[gate]") {
  auto gate = make_gate();
  CHECK(gate.admit(from(1, 1, kNow - 3 * kSecond), CommandClass::kSafety, kNow).refusal == GateRefusal::kStale);
  CHECK(gate.admit(from(1, 2, kNow + 3 * kSecond), CommandClass::kSafety, kNow).refusal == GateRefusal::kStale);
  CHECK(gate.admit(from(1, 3, kNow - kSecond), CommandClass::kSafety, kNow).admitted());
}

TEST_CASE("one client holds control; others may stop and disable but not command", "[gate]") {
  auto gate = make_gate();
  CHECK(gate.holder(kNow) == 0);
  CHECK(gate.admit(from(1, 1), CommandClass::kControlled, kNow).refusal == GateRefusal::kNotInControl);
  REQUIRE(gate.admit(from(1, 2), CommandClass::kTakeControl, kNow).admitted());
  CHECK(gate.holder(kNow) == 1);
  CHECK(gate.lease_remaining_s(kNow) == Approx(30.0));
  CHECK(gate.admit(from(1, 3), CommandClass::kControlled, kNow).admitted());

  const auto taken = gate.admit(from(2, 1), CommandClass::kTakeControl, kNow);
  CHECK(taken.refusal == GateRefusal::kNotInControl);
  CHECK_THAT(taken.reason, Catch::Contains("client 1 holds control"));
  CHECK(gate.admit(from(2, 2), CommandClass::kControlled, kNow).refusal == GateRefusal::kNotInControl);
  CHECK(gate.admit(from(2, 3), CommandClass::kSafety, kNow).admitted());  // stop from anyone
  CHECK(gate.admit(from(2, 4), CommandClass::kReleaseControl, kNow).refusal == GateRefusal::kNotInControl);

  REQUIRE(gate.admit(from(1, 4), CommandClass::kReleaseControl, kNow).admitted());
  CHECK(gate.holder(kNow) == 0);
  CHECK(gate.admit(from(2, 5), CommandClass::kTakeControl, kNow).admitted());
  CHECK(gate.holder(kNow) == 2);
}

TEST_CASE("the holder's commands renew the lease; a lapsed lease frees control", "[gate]") {
  auto gate = make_gate();
  REQUIRE(gate.admit(from(1, 1), CommandClass::kTakeControl, kNow).admitted());
  const std::int64_t later = kNow + 20 * kSecond;
  REQUIRE(gate.admit(from(1, 2, later), CommandClass::kControlled, later).admitted());
  CHECK(gate.lease_remaining_s(later) == Approx(30.0));
  const std::int64_t lapsed = later + 31 * kSecond;
  CHECK(gate.holder(lapsed) == 0);
  CHECK(gate.admit(from(1, 3, lapsed), CommandClass::kControlled, lapsed).refusal == GateRefusal::kNotInControl);
  CHECK(gate.admit(from(2, 1, lapsed), CommandClass::kTakeControl, lapsed).admitted());
}

TEST_CASE("a full client table refuses new clients until a slot is older than max_age_s", "[gate]") {
  auto gate = make_gate();
  for (std::int64_t c = 1; c <= 32; ++c) REQUIRE(gate.admit(from(c, 1), CommandClass::kSafety, kNow).admitted());
  CHECK(gate.admit(from(33, 1), CommandClass::kSafety, kNow).refusal == GateRefusal::kNoClient);
  const std::int64_t later = kNow + 3 * kSecond;
  CHECK(gate.admit(from(33, 1, later), CommandClass::kSafety, later).admitted());
  // The forgotten client's old datagram is stale, so its replay is still refused.
  CHECK(gate.admit(from(1, 1, kNow), CommandClass::kSafety, later).refusal != GateRefusal::kAdmitted);
}

TEST_CASE("settings are validated", "[gate]") {
  CHECK_THROWS_WITH(CommandGate({"", kSession, 2.0, 30.0}), Catch::Contains("axis"));
  CHECK_THROWS_WITH(CommandGate({"a", 0, 2.0, 30.0}), Catch::Contains("session"));
  CHECK_THROWS_WITH(CommandGate({"a", 1, 0.0, 30.0}), Catch::Contains("max_age_s"));
  CHECK_THROWS_WITH(CommandGate({"a", 1, 2.0, -1.0}), Catch::Contains("control_lease_s"));
}
