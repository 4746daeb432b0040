// The bus-side injector of `clm sim --inject` (drivers/sim/bus_injector.hpp)
// on frames made by the codec, checked with the codec's decoders; and the
// drive's latch frame (TPDO2) on its way out of the simulated nodes, through
// the in-process bus and through the injector.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/sim/bus_injector.hpp"
#include "drivers/sim/in_process_bus.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/simulated_nodes.hpp"

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

// --- the drive's latch frame (TPDO2) ------------------------------------------

namespace {

/// The nodes' three replies to SYNC number `k` in the period of a latch: latch, drive, force.
std::array<Frame, 3> replies_with_latch(int k) {
  std::array<Frame, 3> frames{};
  const clm::can::DriveLatch latch{-0.0123, static_cast<std::uint8_t>(k)};
  REQUIRE(clm::can::encode_drive_latch(protocol(), latch, frames[0]) == CodecStatus::kOk);
  const auto cyclic = replies(k);
  frames[1] = cyclic[0];
  frames[2] = cyclic[1];
  return frames;
}

}  // namespace

TEST_CASE("the drive's latch frame passes every injection step at once, unchanged and before the drive feedback",
          "[injector][latch]") {
  const std::vector<std::string> kinds{"drop-drive", "drop-force", "late-drive", "corrupt-reserved", "corrupt-alive",
                                       "corrupt-force-alive", "corrupt-position", "wrong-dlc", "duplicate",
                                       "drive-fault", "push:1:10"};
  for (const std::string& kind : kinds) {
    INFO(kind);
    BusInjector injector(protocol(), clm::sim::parse_injection_plan(kind));
    injector.observe(rpdo1(true));
    injector.request_next();
    const clm::sim::InjectionStep* fired = injector.on_sync();
    REQUIRE(fired != nullptr);
    const auto frames = replies_with_latch(20);
    BusInjector::Replies out;
    injector.transform(frames, out);
    REQUIRE(out.now_count >= 1);
    CHECK(out.now[0].id == clm::can::drive_latch_id(protocol()));
    CHECK(out.now[0].dlc == frames[0].dlc);
    CHECK(out.now[0].data == frames[0].data);
    int latch_frames = 0;
    for (std::size_t k = 0; k < out.now_count; ++k) latch_frames += out.now[k].id == clm::can::drive_latch_id(protocol());
    for (std::size_t k = 0; k < out.late_count; ++k) CHECK(out.late[k].id != clm::can::drive_latch_id(protocol()));
    CHECK(latch_frames == 1);
  }
}

TEST_CASE("corrupt-reserved sets a status bit that is still reserved now that bits 5 and 6 carry the latch and the switch",
          "[injector][latch]") {
  BusInjector injector(protocol(), clm::sim::parse_injection_plan("corrupt-reserved"));
  injector.observe(rpdo1(true));
  injector.request_next();
  REQUIRE(injector.on_sync() != nullptr);
  BusInjector::Replies out;
  injector.transform(replies(3), out);
  REQUIRE(out.now_count == 2);
  const std::uint16_t word = static_cast<std::uint16_t>(out.now[0].data[4] | out.now[0].data[5] << 8);
  CHECK((word & clm::can::kStatusReservedMask) != 0);
  CHECK((word & (clm::can::kStatusLatched | clm::can::kStatusReferenceSwitch)) == 0);
}

namespace {

constexpr double kPeriod_s = 1e-3;
constexpr double kIndexPitch_m = 0.005;

/// A 3-coil-set motor without parasitics, friction or sensor noise, an
/// absolute-looking encoder (no power-up offset) with index marks every 5 mm
/// and a reference switch over [12, 20] mm.
clm::sim::MotorParameters latch_motor() {
  clm::sim::MotorParameters motor;
  motor.stroke_min_m = -0.1;
  motor.stroke_max_m = 0.1;
  auto& em = motor.electromagnetics;
  em.pole_pitch_m = 0.032;
  em.orthogonal_ratio = 0.12;
  for (int l = 0; l < 3; ++l) em.coil_sets.push_back({60.0 + l, -0.5 + 0.02 * l, -0.06 + 0.06 * l, 0.0});
  clm::sim::switch_off_parasitics(em);
  motor.mechanics.translator_mass_kg = 12.0;
  motor.mechanics.end_stop_min_m = -0.11;
  motor.mechanics.end_stop_max_m = 0.11;
  motor.drive.commutation = {67.0, -0.52};
  motor.drive.phase_current_limit_A = 20.0;
  motor.sensors.encoder_resolution_m = 0.0;
  motor.sensors.encoder_noise_m = 0.0;
  motor.sensors.force_noise_N_N_Nm.setZero();
  motor.sensors.force_bias_N_N_Nm.setZero();
  motor.sensors.index_pitch_m = kIndexPitch_m;
  motor.sensors.reference_switch_min_m = 0.012;
  motor.sensors.reference_switch_max_m = 0.020;
  return motor;
}

/// The daemon's RPDOs of one cycle: drive disabled, the latch as given.
std::vector<Frame> latch_rpdos(bool arm, bool on_switch) {
  clm::can::SetpointCommand command;
  command.coil_sets = 3;
  command.arm_latch = arm;
  command.latch_on_switch = on_switch;
  std::array<Frame, clm::can::kMaxSetpointFrames> frames{};
  CodecStatus status = CodecStatus::kWrongId;
  const std::size_t count = clm::can::encode_setpoints(protocol(), command, frames, status);
  REQUIRE(status == CodecStatus::kOk);
  return {frames.begin(), frames.begin() + static_cast<std::ptrdiff_t>(count)};
}

/// One cycle on the nodes: SYNC `k`, its replies into `replies`, then the RPDOs.
std::size_t cycle(clm::sim::SimulatedNodes& nodes, int k, std::span<Frame> replies, const std::vector<Frame>& rpdos) {
  Frame sync;
  REQUIRE(clm::can::encode_sync(static_cast<std::uint8_t>(1 + k % 240), sync) == CodecStatus::kOk);
  const std::size_t count = nodes.on_frame(sync, replies);
  for (const Frame& rpdo : rpdos) REQUIRE(nodes.on_frame(rpdo, std::span<Frame>{}) == 0);
  return count;
}

std::uint16_t status_word(const Frame& drive) {
  clm::can::DriveFeedback feedback;
  REQUIRE(clm::can::decode_drive_feedback(protocol(), drive, feedback) == CodecStatus::kOk);
  return feedback.status_word;
}

}  // namespace

TEST_CASE("the simulated drive sends its latch frame once, first in the period of the latch, with the index mark's "
          "reading and a count that goes up by one per latch",
          "[nodes][latch]") {
  clm::sim::SimulatedMotor motor(latch_motor());
  clm::sim::SimulatedNodes nodes(motor, protocol(), kPeriod_s);
  motor.set_disturbance_force_N(12.0);  // 1 m/s²: past the 5 mm mark in about 100 ms, 0.1 mm per period
  std::array<Frame, clm::sim::SimulatedNodes::kMaxReplies> replies{};
  const auto armed = latch_rpdos(true, false);

  std::vector<clm::can::DriveLatch> latches;
  int latch_cycle = -1;
  for (int k = 0; k < 200 && latches.empty(); ++k) {
    const std::size_t count = cycle(nodes, k, replies, armed);
    if (replies[0].id != clm::can::drive_latch_id(protocol())) {
      REQUIRE(count == 2);
      CHECK((status_word(replies[0]) & clm::can::kStatusLatched) == 0);
      continue;
    }
    REQUIRE(count == 3);
    clm::can::DriveLatch latch;
    REQUIRE(clm::can::decode_drive_latch(protocol(), replies[0], latch) == CodecStatus::kOk);
    latches.push_back(latch);
    latch_cycle = k;
    CHECK(replies[1].id == clm::can::drive_feedback_id(protocol()));
    CHECK((status_word(replies[1]) & clm::can::kStatusLatched) != 0);
    CHECK(replies[2].id == clm::can::force_feedback_id(protocol()));
  }
  REQUIRE(latches.size() == 1);
  REQUIRE(latch_cycle > 0);  // not at once: the first mark ahead is 5 mm away
  CHECK(latches[0].position_m == Approx(kIndexPitch_m).margin(1e-9));
  CHECK(latches[0].latch_count == 0);
  CHECK(nodes.counters().replies_no_room == 0);

  // Once per arming: still armed, no second frame, the bit stays.
  for (int k = latch_cycle + 1; k < latch_cycle + 20; ++k) {
    REQUIRE(cycle(nodes, k, replies, armed) == 2);
    CHECK(replies[0].id == clm::can::drive_feedback_id(protocol()));
    CHECK((status_word(replies[0]) & clm::can::kStatusLatched) != 0);
  }
  // Disarmed: the bit clears in the next period's feedback.
  int k = latch_cycle + 20;
  cycle(nodes, k++, replies, latch_rpdos(false, false));
  REQUIRE(cycle(nodes, k++, replies, latch_rpdos(false, false)) == 2);
  CHECK((status_word(replies[0]) & clm::can::kStatusLatched) == 0);

  // Armed again, on the reference switch: the latch catches its lower edge
  // (12 mm), the count goes to 1, and the switch shows in the status word.
  const auto on_switch = latch_rpdos(true, true);
  bool caught = false;
  for (int end = k + 200; k < end && !caught; ++k) {
    const std::size_t count = cycle(nodes, k, replies, on_switch);
    if (replies[0].id != clm::can::drive_latch_id(protocol())) continue;
    REQUIRE(count == 3);
    clm::can::DriveLatch latch;
    REQUIRE(clm::can::decode_drive_latch(protocol(), replies[0], latch) == CodecStatus::kOk);
    CHECK(latch.position_m == Approx(0.012).margin(1e-9));
    CHECK(latch.latch_count == 1);
    const std::uint16_t word = status_word(replies[1]);
    CHECK((word & clm::can::kStatusLatched) != 0);
    CHECK((word & clm::can::kStatusReferenceSwitch) != 0);
    caught = true;
  }
  CHECK(caught);
}

TEST_CASE("a replies span with room for the cyclic frames only keeps them and counts the latch frame it cannot take",
          "[nodes][latch]") {
  clm::sim::SimulatedMotor motor(latch_motor());
  clm::sim::SimulatedNodes nodes(motor, protocol(), kPeriod_s);
  motor.set_disturbance_force_N(12.0);
  std::array<Frame, 2> replies{};
  const auto armed = latch_rpdos(true, false);
  bool latched = false;
  for (int k = 0; k < 200 && !latched; ++k) {
    REQUIRE(cycle(nodes, k, replies, armed) == 2);
    CHECK(replies[0].id == clm::can::drive_feedback_id(protocol()));
    CHECK(replies[1].id == clm::can::force_feedback_id(protocol()));
    latched = (status_word(replies[0]) & clm::can::kStatusLatched) != 0;
  }
  CHECK(latched);
  CHECK(nodes.counters().replies_no_room == 1);
  CHECK(nodes.counters().feedback_not_encoded == 0);
}

TEST_CASE("on the in-process bus the latch frame arrives in its period, before the drive feedback, even when the "
          "drive feedback is delayed",
          "[nodes][latch][in_process]") {
  for (const bool delay : {false, true}) {
    INFO((delay ? "drive feedback one cycle late" : "no injection"));
    clm::sim::SimulatedMotor motor(latch_motor());
    clm::sim::SimulatedNodes nodes(motor, protocol(), kPeriod_s);
    clm::sim::InProcessBus bus(nodes);
    if (delay) bus.injection().delay_drive_frames = 1000;
    motor.set_disturbance_force_N(12.0);
    const auto armed = latch_rpdos(true, false);
    std::vector<std::uint32_t> latch_period;    // identifiers received after the latch's SYNC
    std::vector<std::uint32_t> next_period;
    int latch_k = -1;
    for (int k = 0; k < 200 && (latch_k < 0 || k <= latch_k + 1); ++k) {
      bus.advance_to(static_cast<std::int64_t>(k) * 1'000'000);
      Frame sync;
      REQUIRE(clm::can::encode_sync(static_cast<std::uint8_t>(1 + k % 240), sync) == CodecStatus::kOk);
      REQUIRE(bus.send(sync));
      std::vector<std::uint32_t> received;
      clm::drivers::ReceivedFrame frame;
      while (bus.receive(frame, 0)) received.push_back(frame.frame.id);
      for (const Frame& rpdo : armed) REQUIRE(bus.send(rpdo));
      if (latch_k >= 0) {
        next_period = received;
      } else if (std::find(received.begin(), received.end(), clm::can::drive_latch_id(protocol())) != received.end()) {
        latch_k = k;
        latch_period = received;
      }
    }
    REQUIRE(latch_k > 0);
    const std::uint32_t latch_id = clm::can::drive_latch_id(protocol());
    const std::uint32_t drive_id = clm::can::drive_feedback_id(protocol());
    const std::uint32_t force_id = clm::can::force_feedback_id(protocol());
    if (!delay) {
      CHECK(latch_period == std::vector<std::uint32_t>{latch_id, drive_id, force_id});
    } else {
      // The previous period's drive frame, held back, comes first; the latch
      // is not held with it, and its own period's drive frame follows later.
      CHECK(latch_period == std::vector<std::uint32_t>{drive_id, latch_id, force_id});
      CHECK(next_period == std::vector<std::uint32_t>{drive_id, force_id});
    }
    CHECK(std::count(next_period.begin(), next_period.end(), latch_id) == 0);
  }
}
