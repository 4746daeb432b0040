// The bus-side injector of `clm sim --inject` (drivers/sim/bus_injector.hpp)
// on frames made by the codec, checked with the codec's decoders.
#include <catch2/catch.hpp>

#include <array>
#include <stdexcept>

#include "drivers/sim/bus_injector.hpp"

namespace {

using clm::can::CodecStatus;
using clm::can::Frame;
using clm::sim::BusInjector;
using clm::sim::InjectionKind;

clm::can::ProtocolConfig protocol() {
  clm::can::ProtocolConfig config;
  config.coil_sets = 3;
  return config;
}

/// The nodes' two replies to SYNC number `k`.
std::array<Frame, 2> replies(int k) {
  std::array<Frame, 2> frames{};
  const clm::can::DriveFeedback drive{0.01 * k, clm::can::kStatusEnabled, static_cast<std::uint8_t>(k)};
  REQUIRE(clm::can::encode_drive_feedback(protocol(), drive, frames[0]) == CodecStatus::kOk);
  const clm::can::ForceFeedback force{clm::Wrench(1.0, 0.5, 0.01), static_cast<std::uint8_t>(k)};
  REQUIRE(clm::can::encode_force_feedback(protocol(), force, frames[1]) == CodecStatus::kOk);
  return frames;
}

Frame rpdo1(bool enable) {
  Frame frame;
  frame.id = clm::can::setpoint_id(protocol(), 0);
  frame.dlc = 6;
  frame.data[0] = enable ? clm::can::kControlEnable : 0;
  return frame;
}

/// One SYNC through the injector: the frames sent at once and late.
BusInjector::Replies sync(BusInjector& injector, int k, const clm::sim::InjectionStep** fired = nullptr) {
  const clm::sim::InjectionStep* step = injector.on_sync();
  if (fired != nullptr) *fired = step;
  BusInjector::Replies out;
  const auto frames = replies(k);
  injector.transform(frames, out);
  return out;
}

int drive_frames(const BusInjector::Replies& out) {
  int count = 0;
  for (std::size_t k = 0; k < out.now_count; ++k) count += out.now[k].id == clm::can::drive_feedback_id(protocol());
  return count;
}

}  // namespace

TEST_CASE("injection plans parse by name and count, and refuse anything else", "[injector]") {
  const auto plan = clm::sim::parse_injection_plan("drop-drive:3,late-drive,drive-fault:1");
  REQUIRE(plan.size() == 3);
  CHECK(plan[0].kind == InjectionKind::kDropDrive);
  CHECK(plan[0].frames == 3);
  CHECK(plan[1].kind == InjectionKind::kLateDrive);
  CHECK(plan[1].frames == 1);
  CHECK(plan[2].kind == InjectionKind::kDriveFault);
  CHECK_THROWS_WITH(clm::sim::parse_injection_plan("drop-drive:3,drop-everything"),
                    Catch::Contains("unknown step 'drop-everything'"));
  CHECK_THROWS_WITH(clm::sim::parse_injection_plan("drop-drive:0"), Catch::Contains("1 … 1000"));
  CHECK_THROWS_WITH(clm::sim::parse_injection_plan("drop-drive:3x"), Catch::Contains("1 … 1000"));
  CHECK_THROWS(clm::sim::parse_injection_plan(""));
}

TEST_CASE("corrupt-force-alive advances the force sensor's alive counter in one frame only", "[injector]") {
  BusInjector injector(protocol(), clm::sim::parse_injection_plan("corrupt-force-alive"));
  injector.observe(rpdo1(true));
  injector.request_next();
  const auto alive = [](const BusInjector::Replies& out) {
    clm::can::ForceFeedback force;
    for (std::size_t k = 0; k < out.now_count; ++k) {
      if (out.now[k].id != clm::can::force_feedback_id(protocol())) continue;
      REQUIRE(clm::can::decode_force_feedback(protocol(), out.now[k], force) == CodecStatus::kOk);
      return static_cast<int>(force.alive_counter);
    }
    return -1;
  };
  CHECK(alive(sync(injector, 5)) == 5 + 7);
  CHECK(alive(sync(injector, 6)) == 6);
}

TEST_CASE("a push step carries its force and is active for exactly its SYNCs", "[injector]") {
  const auto plan = clm::sim::parse_injection_plan("push:3:700,drop-drive");
  REQUIRE(plan.size() == 2);
  CHECK(plan[0].kind == InjectionKind::kPush);
  CHECK(plan[0].frames == 3);
  CHECK(plan[0].value == 700.0);
  CHECK_THROWS_WITH(clm::sim::parse_injection_plan("push:3"), Catch::Contains("force F > 0 N"));
  CHECK_THROWS_WITH(clm::sim::parse_injection_plan("push:3:-1"), Catch::Contains("force F > 0 N"));
  CHECK_THROWS_WITH(clm::sim::parse_injection_plan("drop-drive:3:1"), Catch::Contains("takes no value"));
  BusInjector injector(protocol(), plan);
  injector.observe(rpdo1(true));
  injector.request_next();
  const clm::sim::InjectionStep* fired = nullptr;
  CHECK(drive_frames(sync(injector, 1, &fired)) == 1);  // a push touches no frame
  REQUIRE(fired != nullptr);
  CHECK(fired->kind == InjectionKind::kPush);
  CHECK(injector.push_active());
  sync(injector, 2, &fired);
  CHECK(injector.push_active());
  sync(injector, 3, &fired);
  CHECK(injector.push_active());
  sync(injector, 4, &fired);
  CHECK_FALSE(injector.push_active());
}

TEST_CASE("a requested step fires only at a SYNC with the axis enabled and acts on exactly its frames", "[injector]") {
  BusInjector injector(protocol(), clm::sim::parse_injection_plan("drop-drive:3,duplicate"));
  injector.request_next();
  const clm::sim::InjectionStep* fired = nullptr;
  CHECK(drive_frames(sync(injector, 1, &fired)) == 1);  // disabled: waits
  CHECK(fired == nullptr);
  injector.observe(rpdo1(true));
  CHECK(drive_frames(sync(injector, 2, &fired)) == 0);
  REQUIRE(fired != nullptr);
  CHECK(fired->kind == InjectionKind::kDropDrive);
  CHECK(drive_frames(sync(injector, 3)) == 0);
  CHECK(drive_frames(sync(injector, 4)) == 0);
  const auto after = sync(injector, 5);
  CHECK(drive_frames(after) == 1);
  CHECK(after.now_count == 2);  // the force sensor's frame was never touched
  injector.request_next();
  const auto twice = sync(injector, 6, &fired);
  REQUIRE(fired != nullptr);
  CHECK(fired->kind == InjectionKind::kDuplicate);
  CHECK(drive_frames(twice) == 2);
  CHECK(drive_frames(sync(injector, 7)) == 1);
  injector.request_next();  // beyond the plan
  CHECK(injector.requests_ignored() == 1);
  CHECK(drive_frames(sync(injector, 8, &fired)) == 1);
  CHECK(fired == nullptr);
}

TEST_CASE("corrupted, short and late drive frames are what the daemon's decoder refuses or gets late", "[injector]") {
  BusInjector injector(protocol(),
                       clm::sim::parse_injection_plan("corrupt-reserved,wrong-dlc,corrupt-alive:2,corrupt-position,late-drive,drop-force"));
  injector.observe(rpdo1(true));
  clm::can::DriveFeedback decoded;

  injector.request_next();
  auto out = sync(injector, 10);
  CHECK(clm::can::decode_drive_feedback(protocol(), out.now[0], decoded) == CodecStatus::kOutOfRange);

  injector.request_next();
  out = sync(injector, 11);
  CHECK(out.now[0].dlc == 6);
  CHECK(clm::can::decode_drive_feedback(protocol(), out.now[0], decoded) == CodecStatus::kWrongLength);

  injector.request_next();
  out = sync(injector, 12);
  REQUIRE(clm::can::decode_drive_feedback(protocol(), out.now[0], decoded) == CodecStatus::kOk);
  CHECK(decoded.alive_counter == 12 + 7);
  out = sync(injector, 13);  // the jump happens once; the second frame keeps its counter
  REQUIRE(clm::can::decode_drive_feedback(protocol(), out.now[0], decoded) == CodecStatus::kOk);
  CHECK(decoded.alive_counter == 13);

  injector.request_next();
  out = sync(injector, 14);
  REQUIRE(clm::can::decode_drive_feedback(protocol(), out.now[0], decoded) == CodecStatus::kOk);
  CHECK(std::abs(decoded.position_m - 0.14) == Approx(0.536870912).margin(1e-9));

  injector.request_next();
  out = sync(injector, 15);
  CHECK(drive_frames(out) == 0);
  REQUIRE(out.late_count == 1);
  CHECK(out.late[0].id == clm::can::drive_feedback_id(protocol()));

  injector.request_next();
  out = sync(injector, 16);
  REQUIRE(out.now_count == 1);
  CHECK(out.now[0].id == clm::can::drive_feedback_id(protocol()));
}
