// Command authority (daemon/servod/command_gate.hpp): axis, session, client,
// sequence, age and the control lease, each refusal counted by kind.
#include <catch2/catch.hpp>

#include "daemon/servod/command_gate.hpp"

using namespace clm::servod;
using Result = clm::servo::CommandResult;

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
  CHECK(d.result == Result::kRejectedOtherAxis);
  CHECK_THAT(d.detail, Catch::Contains("y-axis") && Catch::Contains("x-axis"));
  origin = from(1, 1);
  origin.session = kSession + 1;
  CHECK(gate.admit(origin, CommandClass::kRead, kNow).result == Result::kRejectedOtherSession);
  CHECK(gate.admit(origin, CommandClass::kTakeControl, kNow).result == Result::kRejectedOtherSession);
  CHECK(gate.count(Result::kRejectedOtherAxis) == 1);
  CHECK(gate.count(Result::kRejectedOtherSession) == 2);
  CHECK(gate.count(Result::kAccepted) == 0);
}

TEST_CASE("stop, quick stop and disable naming the axis are admitted from anyone: any session, age, client or sequence",
          "[gate][safety]") {
  auto gate = make_gate();
  auto origin = from(0, 0, kNow - 3600 * kSecond);  // client 0, sequence 0, an hour old
  origin.session = kSession + 1;
  CHECK(gate.admit(origin, CommandClass::kSafety, kNow).accepted());
  CHECK(gate.admit(origin, CommandClass::kSafety, kNow).accepted());  // the same again
  CHECK(gate.admit_safety("x-axis"));
  CHECK_FALSE(gate.admit_safety("y-axis"));
  // Control held by another client changes nothing.
  REQUIRE(gate.admit(from(1, 1), CommandClass::kTakeControl, kNow).accepted());
  CHECK(gate.admit(from(2, 1), CommandClass::kSafety, kNow).accepted());
  CHECK(gate.holder(kNow) == 1);
  CHECK(gate.count(Result::kAccepted) == 5);
}

TEST_CASE("a repeated or older sequence from the same client is refused, other clients count their own", "[gate]") {
  auto gate = make_gate();
  REQUIRE(gate.admit(from(7, 100), CommandClass::kTakeControl, kNow).accepted());
  CHECK(gate.admit(from(7, 100), CommandClass::kControlled, kNow).result == Result::kRejectedReplayed);
  CHECK(gate.admit(from(7, 99), CommandClass::kControlled, kNow).result == Result::kRejectedReplayed);
  CHECK(gate.admit(from(7, 101), CommandClass::kControlled, kNow).accepted());
  REQUIRE(gate.admit(from(7, 102), CommandClass::kReleaseControl, kNow).accepted());
  CHECK(gate.admit(from(8, 1), CommandClass::kTakeControl, kNow).accepted());
  CHECK(gate.admit(from(8, 0), CommandClass::kControlled, kNow).result == Result::kRejectedReplayed);
  CHECK(gate.count(Result::kRejectedReplayed) == 3);
  CHECK(gate.admit(from(0, 5), CommandClass::kRead, kNow).result == Result::kRejectedNoClient);
}

TEST_CASE("commands older than max_age_s, or from the future, are refused", "[gate]") {
  auto gate = make_gate();
  CHECK(gate.admit(from(1, 1, kNow - 3 * kSecond), CommandClass::kRead, kNow).result == Result::kRejectedStale);
  CHECK(gate.admit(from(1, 2, kNow + 3 * kSecond), CommandClass::kTakeControl, kNow).result == Result::kRejectedStale);
  CHECK(gate.admit(from(1, 3, kNow - kSecond), CommandClass::kRead, kNow).accepted());
}

TEST_CASE("reads take no client slot: forged clients without end leave the holder's replay protection intact",
          "[gate][safety]") {
  auto gate = make_gate();
  REQUIRE(gate.admit(from(1, 10), CommandClass::kTakeControl, kNow).accepted());
  // 10,000 made-up clients: reads, safety commands, refused take_control and commands.
  for (std::int64_t c = 100; c < 10'100; ++c) {
    REQUIRE(gate.admit(from(c, 1), CommandClass::kRead, kNow).accepted());
    REQUIRE(gate.admit(from(c, 2), CommandClass::kSafety, kNow).accepted());
    REQUIRE(gate.admit(from(c, 3), CommandClass::kTakeControl, kNow).result == Result::kRejectedNotInControl);
    REQUIRE(gate.admit(from(c, 4), CommandClass::kControlled, kNow).result == Result::kRejectedNotInControl);
  }
  CHECK(gate.admit(from(1, 10), CommandClass::kControlled, kNow).result == Result::kRejectedReplayed);
  CHECK(gate.admit(from(1, 11), CommandClass::kControlled, kNow).accepted());
  CHECK(gate.count(Result::kRejectedNoClient) == 0);
}

TEST_CASE("a full client table forgets the client seen longest ago, and a replay of its datagrams is still refused",
          "[gate]") {
  auto gate = make_gate();
  // 33 clients take and release control in turn, 1 ms apart: client 1 is forgotten.
  for (std::int64_t c = 1; c <= 33; ++c) {
    const std::int64_t t = kNow + c * 1000;
    REQUIRE(gate.admit(from(c, 1, t), CommandClass::kTakeControl, t).accepted());
    REQUIRE(gate.admit(from(c, 2, t), CommandClass::kReleaseControl, t).accepted());
  }
  const std::int64_t later = kNow + 100 * 1000;
  // Client 1's take_control datagram again (within max_age_s): refused as a replay.
  const auto replay = gate.admit(from(1, 1, kNow + 1000), CommandClass::kTakeControl, later);
  CHECK(replay.result == Result::kRejectedReplayed);
  // A fresh command of client 1 is admitted; no client is ever refused for room.
  CHECK(gate.admit(from(1, 3, later), CommandClass::kTakeControl, later).accepted());
  CHECK(gate.count(Result::kRejectedNoClient) == 0);
}

TEST_CASE("one client holds control, others may stop and disable but not command", "[gate]") {
  auto gate = make_gate();
  CHECK(gate.holder(kNow) == 0);
  CHECK(gate.admit(from(1, 1), CommandClass::kControlled, kNow).result == Result::kRejectedNotInControl);
  REQUIRE(gate.admit(from(1, 2), CommandClass::kTakeControl, kNow).accepted());
  CHECK(gate.holder(kNow) == 1);
  CHECK(gate.lease_remaining_s(kNow) == Approx(30.0));
  CHECK(gate.admit(from(1, 3), CommandClass::kControlled, kNow).accepted());

  const auto taken = gate.admit(from(2, 1), CommandClass::kTakeControl, kNow);
  CHECK(taken.result == Result::kRejectedNotInControl);
  CHECK_THAT(taken.detail, Catch::Contains("client 1 holds control"));
  CHECK(gate.admit(from(2, 2), CommandClass::kControlled, kNow).result == Result::kRejectedNotInControl);
  CHECK(gate.admit(from(2, 3), CommandClass::kSafety, kNow).accepted());  // stop from anyone
  CHECK(gate.admit(from(2, 4), CommandClass::kReleaseControl, kNow).result == Result::kRejectedNotInControl);

  REQUIRE(gate.admit(from(1, 4), CommandClass::kReleaseControl, kNow).accepted());
  CHECK(gate.holder(kNow) == 0);
  CHECK(gate.admit(from(2, 5), CommandClass::kTakeControl, kNow).accepted());
  CHECK(gate.holder(kNow) == 2);
}

TEST_CASE("the holder's commands renew the lease, a lapsed lease frees control", "[gate]") {
  auto gate = make_gate();
  REQUIRE(gate.admit(from(1, 1), CommandClass::kTakeControl, kNow).accepted());
  const std::int64_t later = kNow + 20 * kSecond;
  REQUIRE(gate.admit(from(1, 2, later), CommandClass::kControlled, later).accepted());
  CHECK(gate.lease_remaining_s(later) == Approx(30.0));
  const std::int64_t lapsed = later + 31 * kSecond;
  CHECK(gate.holder(lapsed) == 0);
  CHECK(gate.admit(from(1, 3, lapsed), CommandClass::kControlled, lapsed).result == Result::kRejectedNotInControl);
  CHECK(gate.admit(from(2, 1, lapsed), CommandClass::kTakeControl, lapsed).accepted());
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
  REQUIRE(gate.admit(from(1, 10), CommandClass::kTakeControl, kNow).accepted());
  CHECK_FALSE(gate.deadman());
  CHECK(gate.lease_remaining_s(kNow) == Approx(30.0));
  // Only the holder renews; no sequence is kept, so an older one is no replay.
  CHECK(gate.admit(from(2, 1), CommandClass::kRenewControl, kNow).result == Result::kRejectedNotInControl);
  REQUIRE(gate.admit(from(1, 5), CommandClass::kRenewControl, kNow).accepted());
  CHECK(gate.deadman());
  CHECK(gate.lease_remaining_s(kNow) == Approx(0.5));
  CHECK(gate.admit(from(1, 11), CommandClass::kControlled, kNow).accepted());  // sequence 10 is still the last
  // Renewed by a command 0.4 s later: still held at 0.8 s, nothing lapsed.
  const std::int64_t t1 = kNow + 400'000;
  REQUIRE(gate.admit(from(1, 12, t1), CommandClass::kControlled, t1).accepted());
  CHECK(gate.take_lapsed_deadman(kNow + 800'000) == 0);
  CHECK(gate.holder(kNow + 800'000) == 1);
  // 0.5 s after the last command: lapsed, handed over exactly once, control free.
  CHECK(gate.take_lapsed_deadman(t1 + 500'000) == 1);
  CHECK(gate.take_lapsed_deadman(t1 + 500'000) == 0);
  CHECK(gate.holder(t1 + 500'000) == 0);
  CHECK_FALSE(gate.deadman());
  // The next holder starts with an ordinary lease, which never hands anyone over.
  REQUIRE(gate.admit(from(2, 1, t1), CommandClass::kTakeControl, t1 + 500'000).accepted());
  CHECK_FALSE(gate.deadman());
  CHECK(gate.take_lapsed_deadman(t1 + 100 * kSecond) == 0);
}

TEST_CASE("a release ends a deadman lease without a lapse", "[gate][deadman]") {
  CommandGate gate({"x-axis", kSession, 2.0, 30.0, 0.5});
  REQUIRE(gate.admit(from(1, 1), CommandClass::kTakeControl, kNow).accepted());
  REQUIRE(gate.admit(from(1, 1), CommandClass::kRenewControl, kNow).accepted());
  REQUIRE(gate.admit(from(1, 2), CommandClass::kReleaseControl, kNow).accepted());
  CHECK_FALSE(gate.deadman());
  CHECK(gate.take_lapsed_deadman(kNow + kSecond) == 0);
  CHECK_THROWS_WITH(CommandGate({"x-axis", kSession, 2.0, 30.0, 0.01}), Catch::Contains("deadman_timeout_s"));
}
