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
  CHECK(gate.admit(origin, CommandClass::kRead, kNow).refusal == GateRefusal::kOtherSession);
  CHECK(gate.admit(origin, CommandClass::kTakeControl, kNow).refusal == GateRefusal::kOtherSession);
  CHECK(gate.count(GateRefusal::kOtherAxis) == 1);
  CHECK(gate.count(GateRefusal::kOtherSession) == 2);
  CHECK(gate.count(GateRefusal::kAdmitted) == 0);
}

TEST_CASE("stop, quick stop and disable naming the axis are admitted from anyone: any session, age, client or sequence",
          "[gate][safety]") {
  auto gate = make_gate();
  auto origin = from(0, 0, kNow - 3600 * kSecond);  // client 0, sequence 0, an hour old
  origin.session = kSession + 1;
  CHECK(gate.admit(origin, CommandClass::kSafety, kNow).admitted());
  CHECK(gate.admit(origin, CommandClass::kSafety, kNow).admitted());  // the same again
  CHECK(gate.admit_safety("x-axis"));
  CHECK_FALSE(gate.admit_safety("y-axis"));
  // Control held by another client changes nothing.
  REQUIRE(gate.admit(from(1, 1), CommandClass::kTakeControl, kNow).admitted());
  CHECK(gate.admit(from(2, 1), CommandClass::kSafety, kNow).admitted());
  CHECK(gate.holder(kNow) == 1);
  CHECK(gate.count(GateRefusal::kAdmitted) == 5);
}

TEST_CASE("a repeated or older sequence from the same client is refused; other clients count their own", "[gate]") {
  auto gate = make_gate();
  REQUIRE(gate.admit(from(7, 100), CommandClass::kTakeControl, kNow).admitted());
  CHECK(gate.admit(from(7, 100), CommandClass::kControlled, kNow).refusal == GateRefusal::kReplayed);
  CHECK(gate.admit(from(7, 99), CommandClass::kControlled, kNow).refusal == GateRefusal::kReplayed);
  CHECK(gate.admit(from(7, 101), CommandClass::kControlled, kNow).admitted());
  REQUIRE(gate.admit(from(7, 102), CommandClass::kReleaseControl, kNow).admitted());
  CHECK(gate.admit(from(8, 1), CommandClass::kTakeControl, kNow).admitted());
  CHECK(gate.admit(from(8, 0), CommandClass::kControlled, kNow).refusal == GateRefusal::kReplayed);
  CHECK(gate.count(GateRefusal::kReplayed) == 3);
  CHECK(gate.admit(from(0, 5), CommandClass::kRead, kNow).refusal == GateRefusal::kNoClient);
}

TEST_CASE("commands older than max_age_s, or from the future, are refused", "[gate]") {
  auto gate = make_gate();
  CHECK(gate.admit(from(1, 1, kNow - 3 * kSecond), CommandClass::kRead, kNow).refusal == GateRefusal::kStale);
  CHECK(gate.admit(from(1, 2, kNow + 3 * kSecond), CommandClass::kTakeControl, kNow).refusal == GateRefusal::kStale);
  CHECK(gate.admit(from(1, 3, kNow - kSecond), CommandClass::kRead, kNow).admitted());
}

TEST_CASE("reads take no client slot: forged clients without end leave the holder's replay protection intact",
          "[gate][safety]") {
  auto gate = make_gate();
  REQUIRE(gate.admit(from(1, 10), CommandClass::kTakeControl, kNow).admitted());
  // 10,000 made-up clients: reads, safety commands, refused take_control and commands.
  for (std::int64_t c = 100; c < 10'100; ++c) {
    REQUIRE(gate.admit(from(c, 1), CommandClass::kRead, kNow).admitted());
    REQUIRE(gate.admit(from(c, 2), CommandClass::kSafety, kNow).admitted());
    REQUIRE(gate.admit(from(c, 3), CommandClass::kTakeControl, kNow).refusal == GateRefusal::kNotInControl);
    REQUIRE(gate.admit(from(c, 4), CommandClass::kControlled, kNow).refusal == GateRefusal::kNotInControl);
  }
  CHECK(gate.admit(from(1, 10), CommandClass::kControlled, kNow).refusal == GateRefusal::kReplayed);
  CHECK(gate.admit(from(1, 11), CommandClass::kControlled, kNow).admitted());
  CHECK(gate.count(GateRefusal::kNoClient) == 0);
}

TEST_CASE("a full client table forgets the client seen longest ago, and a replay of its datagrams is still refused",
          "[gate]") {
  auto gate = make_gate();
  // 33 clients take and release control in turn, 1 ms apart: client 1 is forgotten.
  for (std::int64_t c = 1; c <= 33; ++c) {
    const std::int64_t t = kNow + c * 1000;
    REQUIRE(gate.admit(from(c, 1, t), CommandClass::kTakeControl, t).admitted());
    REQUIRE(gate.admit(from(c, 2, t), CommandClass::kReleaseControl, t).admitted());
  }
  const std::int64_t later = kNow + 100 * 1000;
  // Client 1's take_control datagram again (within max_age_s): refused as a replay.
  const auto replay = gate.admit(from(1, 1, kNow + 1000), CommandClass::kTakeControl, later);
  CHECK(replay.refusal == GateRefusal::kReplayed);
  // A fresh command of client 1 is admitted; no client is ever refused for room.
  CHECK(gate.admit(from(1, 3, later), CommandClass::kTakeControl, later).admitted());
  CHECK(gate.count(GateRefusal::kNoClient) == 0);
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

TEST_CASE("settings are validated", "[gate]") {
  CHECK_THROWS_WITH(CommandGate({"", kSession, 2.0, 30.0}), Catch::Contains("axis"));
  CHECK_THROWS_WITH(CommandGate({"a", 0, 2.0, 30.0}), Catch::Contains("session"));
  CHECK_THROWS_WITH(CommandGate({"a", 1, 0.0, 30.0}), Catch::Contains("max_age_s"));
  CHECK_THROWS_WITH(CommandGate({"a", 1, 2.0, -1.0}), Catch::Contains("control_lease_s"));
}

TEST_CASE("renew_control makes the holder's lease a deadman lease that lapses after deadman_timeout_s, handed over once",
          "[gate][deadman]") {
  CommandGate gate({"x-axis", kSession, 2.0, 30.0, 0.5});
  REQUIRE(gate.admit(from(1, 10), CommandClass::kTakeControl, kNow).admitted());
  CHECK_FALSE(gate.deadman());
  CHECK(gate.lease_remaining_s(kNow) == Approx(30.0));
  // Only the holder renews; no sequence is kept, so an older one is no replay.
  CHECK(gate.admit(from(2, 1), CommandClass::kRenewControl, kNow).refusal == GateRefusal::kNotInControl);
  REQUIRE(gate.admit(from(1, 5), CommandClass::kRenewControl, kNow).admitted());
  CHECK(gate.deadman());
  CHECK(gate.lease_remaining_s(kNow) == Approx(0.5));
  CHECK(gate.admit(from(1, 11), CommandClass::kControlled, kNow).admitted());  // sequence 10 is still the last
  // Renewed by a command 0.4 s later: still held at 0.8 s, nothing lapsed.
  const std::int64_t t1 = kNow + 400'000;
  REQUIRE(gate.admit(from(1, 12, t1), CommandClass::kControlled, t1).admitted());
  CHECK(gate.take_lapsed_deadman(kNow + 800'000) == 0);
  CHECK(gate.holder(kNow + 800'000) == 1);
  // 0.5 s after the last command: lapsed, handed over exactly once, control free.
  CHECK(gate.take_lapsed_deadman(t1 + 500'000) == 1);
  CHECK(gate.take_lapsed_deadman(t1 + 500'000) == 0);
  CHECK(gate.holder(t1 + 500'000) == 0);
  CHECK_FALSE(gate.deadman());
  // The next holder starts with an ordinary lease, which never hands anyone over.
  REQUIRE(gate.admit(from(2, 1, t1), CommandClass::kTakeControl, t1 + 500'000).admitted());
  CHECK_FALSE(gate.deadman());
  CHECK(gate.take_lapsed_deadman(t1 + 100 * kSecond) == 0);
}

TEST_CASE("a release ends a deadman lease without a lapse", "[gate][deadman]") {
  CommandGate gate({"x-axis", kSession, 2.0, 30.0, 0.5});
  REQUIRE(gate.admit(from(1, 1), CommandClass::kTakeControl, kNow).admitted());
  REQUIRE(gate.admit(from(1, 1), CommandClass::kRenewControl, kNow).admitted());
  REQUIRE(gate.admit(from(1, 2), CommandClass::kReleaseControl, kNow).admitted());
  CHECK_FALSE(gate.deadman());
  CHECK(gate.take_lapsed_deadman(kNow + kSecond) == 0);
  CHECK_THROWS_WITH(CommandGate({"x-axis", kSession, 2.0, 30.0, 0.01}), Catch::Contains("deadman_timeout_s"));
}
