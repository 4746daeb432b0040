// The setpoint RPDOs of a drive with profile phase_current
// (docs/can-protocol.md, "Setpoints of a phase-current drive"): i_a, i_b per
// coil set as int16 in 1 mA, on the identifiers and DLCs of the
// magnitude/phase layout. Hand-computed bytes, range ends, refusals that
// write nothing, seeded round trips, and no allocation.

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "drivers/can/can_protocol.hpp"
#include "drivers/can_frames.hpp"
#include "support/allocation_counter.hpp"

namespace can = clm::can;
using can::CodecStatus;
using can::Frame;
using clm::test::frame_of;
using clm::test::same_frame;
using clm::test::sentinel_frame;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

can::ProtocolConfig phase_current_config(int coil_sets) {
  can::ProtocolConfig config;
  config.coil_sets = coil_sets;
  config.drive_profile = clm::DriveProfile::kPhaseCurrent;
  return config;
}

can::SetpointCommand hand_currents(int coil_sets) {
  can::SetpointCommand command;
  command.enable = true;
  command.alive_counter = 0x10;
  command.coil_sets = coil_sets;
  command.currents[0] = {4.0, -5.0};         // 4000 = 0x0FA0, -5000 = 0xEC78
  command.currents[1] = {-0.001, 32.767};    // -1 = 0xFFFF, 32767 = 0x7FFF (the range ends)
  command.currents[2] = {32.767, -32.768};   // 0x7FFF, -32768 = 0x8000
  command.currents[3] = {0.0, 0.001};        // 0, 1
  // The magnitude/phase array holds values that would not even fit its own
  // fields: with profile phase_current it is neither sent nor checked.
  for (auto& setpoint : command.setpoints) setpoint = {1e6, kNaN};
  return command;
}

}  // namespace

TEST_CASE("phase-current RPDOs carry i_a and i_b in 1 mA with the hand-computed layouts", "[can][setpoint][phase_current]") {
  CHECK(can::kCurrentLsb_A == 1e-3);
  std::array<Frame, 4> frames{sentinel_frame(), sentinel_frame(), sentinel_frame(), sentinel_frame()};
  CodecStatus status = CodecStatus::kWrongId;
  REQUIRE(can::encode_setpoints(phase_current_config(4), hand_currents(4), frames, status) == 3);
  CHECK(status == CodecStatus::kOk);
  // Same identifiers and DLCs as the magnitude/phase profile.
  CHECK(same_frame(frames[0], frame_of(0x201, {0x01, 0x10, 0xA0, 0x0F, 0x78, 0xEC})));
  CHECK(same_frame(frames[1], frame_of(0x301, {0xFF, 0xFF, 0xFF, 0x7F, 0xFF, 0x7F, 0x00, 0x80})));
  CHECK(same_frame(frames[2], frame_of(0x401, {0x00, 0x00, 0x01, 0x00})));
  CHECK(same_frame(frames[3], sentinel_frame()));

  // For L = 2 the coil-set-3 fields are zero, as with magnitude/phase.
  frames.fill(sentinel_frame());
  REQUIRE(can::encode_setpoints(phase_current_config(2), hand_currents(2), frames, status) == 2);
  CHECK(same_frame(frames[1], frame_of(0x301, {0xFF, 0xFF, 0xFF, 0x7F, 0x00, 0x00, 0x00, 0x00})));
}

TEST_CASE("phase-current RPDOs decode to the hand-computed currents and exactly the range ends",
          "[can][setpoint][phase_current]") {
  const auto config = phase_current_config(4);
  can::SetpointCommand received;
  REQUIRE(can::decode_setpoint_frame(config, frame_of(0x201, {0x03, 0x2A, 0xA0, 0x0F, 0x78, 0xEC}), received) ==
          CodecStatus::kOk);
  REQUIRE(can::decode_setpoint_frame(config, frame_of(0x301, {0xFF, 0xFF, 0xFF, 0x7F, 0xFF, 0x7F, 0x00, 0x80}),
                                     received) == CodecStatus::kOk);
  REQUIRE(can::decode_setpoint_frame(config, frame_of(0x401, {0x00, 0x00, 0x01, 0x00}), received) ==
          CodecStatus::kOk);
  CHECK(received.enable);
  CHECK(received.clear_fault);
  CHECK(received.alive_counter == 0x2A);
  CHECK(received.coil_sets == 4);
  CHECK(received.currents[0].ia_A == 4.0);
  CHECK(received.currents[0].ib_A == -5.0);
  CHECK(received.currents[1].ia_A == -0.001);
  CHECK(received.currents[1].ib_A == 32.767);
  CHECK(received.currents[2].ia_A == 32.767);
  CHECK(received.currents[2].ib_A == -32.768);
  CHECK(received.currents[3].ia_A == 0.0);
  CHECK(received.currents[3].ib_A == 0.001);
  // The magnitude/phase array is left alone.
  for (const auto& setpoint : received.setpoints) {
    CHECK(setpoint.magnitude_N == 0.0);
    CHECK(setpoint.delta_rad == 0.0);
  }
  // L = 2: non-zero coil-set-3 fields mean the two ends disagree on L.
  CHECK(can::decode_setpoint_frame(phase_current_config(2), frame_of(0x301, {0, 0, 0, 0, 1, 0, 0, 0}), received) ==
        CodecStatus::kOutOfRange);
  // L = 3 has no RPDO3.
  CHECK(can::decode_setpoint_frame(phase_current_config(3), frame_of(0x401, {0, 0, 0, 0}), received) ==
        CodecStatus::kWrongId);
}

TEST_CASE("phase-current encoding refuses one LSB beyond each range end and non-finite currents and writes nothing",
          "[can][setpoint][phase_current]") {
  const auto config = phase_current_config(4);
  const std::array<Frame, 3> untouched{sentinel_frame(), sentinel_frame(), sentinel_frame()};
  for (std::size_t l = 0; l < 4; ++l) {
    for (int component = 0; component < 2; ++component) {
      const std::vector<std::pair<double, CodecStatus>> cases{
          {32.768, CodecStatus::kOutOfRange},     // 32768 raw: one beyond int16
          {-32.769, CodecStatus::kOutOfRange},    // -32769 raw
          {32.7675, CodecStatus::kOutOfRange},    // rounds (half away from zero) to 32768: refused, never clamped
          {1e300, CodecStatus::kOutOfRange},
          {kNaN, CodecStatus::kNotFinite},
          {kInf, CodecStatus::kNotFinite},
          {-kInf, CodecStatus::kNotFinite}};
      for (const auto& [value, expected] : cases) {
        INFO("coil set " << l + 1 << " component " << component << " value " << value);
        auto command = hand_currents(4);
        (component == 0 ? command.currents[l].ia_A : command.currents[l].ib_A) = value;
        std::array<Frame, 3> frames = untouched;
        CodecStatus status = CodecStatus::kOk;
        CHECK(can::encode_setpoints(config, command, frames, status) == 0);
        CHECK(status == expected);
        for (std::size_t f = 0; f < frames.size(); ++f) CHECK(same_frame(frames[f], untouched[f]));
      }
    }
  }
  // The range ends themselves and half an LSB inside them are accepted.
  auto command = hand_currents(4);
  command.currents[0] = {32.7674, -32.7684};
  std::array<Frame, 3> frames{};
  CodecStatus status = CodecStatus::kWrongId;
  REQUIRE(can::encode_setpoints(config, command, frames, status) == 3);
  CHECK(status == CodecStatus::kOk);
  CHECK(same_frame(frames[0], frame_of(0x201, {0x01, 0x10, 0xFF, 0x7F, 0x00, 0x80})));
}

TEST_CASE("the phase-current RPDO1 carries the latch control bits as magnitude/phase does and refuses bits 4..7",
          "[can][setpoint][phase_current][latch]") {
  const auto config = phase_current_config(1);
  auto command = hand_currents(1);
  command.arm_latch = true;
  command.latch_on_switch = true;
  std::array<Frame, 3> frames{};
  CodecStatus status = CodecStatus::kWrongId;
  REQUIRE(can::encode_setpoints(config, command, frames, status) == 1);
  CHECK(same_frame(frames[0], frame_of(0x201, {0x0D, 0x10, 0xA0, 0x0F, 0x78, 0xEC})));
  can::SetpointCommand received;
  REQUIRE(can::decode_setpoint_frame(config, frames[0], received) == CodecStatus::kOk);
  CHECK(received.enable);
  CHECK_FALSE(received.clear_fault);
  CHECK(received.arm_latch);
  CHECK(received.latch_on_switch);
  CHECK(received.currents[0].ia_A == 4.0);
  for (int bit = 4; bit < 8; ++bit) {
    INFO("control bit " << bit);
    const auto control = static_cast<std::uint8_t>(1u << bit);
    CHECK(can::decode_setpoint_frame(config, frame_of(0x201, {control, 0x10, 0xA0, 0x0F, 0x78, 0xEC}), received) ==
          CodecStatus::kOutOfRange);
  }
}

TEST_CASE("phase currents round-trip random values for every L within half a milliampere",
          "[can][setpoint][phase_current][property]") {
  std::mt19937_64 random(9701);
  std::uniform_real_distribution<double> current(-32.768, 32.767);
  for (int l = 1; l <= 4; ++l) {
    const auto config = phase_current_config(l);
    for (int i = 0; i < 20000; ++i) {
      can::SetpointCommand sent;
      sent.coil_sets = l;
      sent.enable = i % 2 == 0;
      sent.alive_counter = static_cast<std::uint8_t>(i);
      for (int k = 0; k < l; ++k) sent.currents[static_cast<std::size_t>(k)] = {current(random), current(random)};
      std::array<Frame, 3> frames{};
      CodecStatus status = CodecStatus::kWrongId;
      const std::size_t count = can::encode_setpoints(config, sent, frames, status);
      REQUIRE(status == CodecStatus::kOk);
      REQUIRE(count == can::setpoint_frame_count(l));
      can::SetpointCommand received;
      for (std::size_t f = 0; f < count; ++f) {
        REQUIRE(can::decode_setpoint_frame(config, frames[f], received) == CodecStatus::kOk);
      }
      REQUIRE(received.enable == sent.enable);
      REQUIRE(received.alive_counter == sent.alive_counter);
      for (std::size_t k = 0; k < static_cast<std::size_t>(l); ++k) {
        REQUIRE(std::abs(received.currents[k].ia_A - sent.currents[k].ia_A) <= 0.5e-3 * (1 + 1e-6));
        REQUIRE(std::abs(received.currents[k].ib_A - sent.currents[k].ib_A) <= 0.5e-3 * (1 + 1e-6));
      }
    }
  }
}

TEST_CASE("the profile keeps the frame schedule: bus load is the same for both profiles", "[can][phase_current]") {
  for (int l = 1; l <= 4; ++l) {
    can::ProtocolConfig magnitude_phase;
    magnitude_phase.coil_sets = l;
    CHECK(can::cycle_bits(phase_current_config(l)) == can::cycle_bits(magnitude_phase));
  }
  CHECK(can::cycle_bits(phase_current_config(3)) == 575u);
}

TEST_CASE("a drive profile that is neither magnitude_phase nor phase_current is refused", "[can][phase_current]") {
  auto config = phase_current_config(3);
  config.drive_profile = static_cast<clm::DriveProfile>(7);
  CHECK_FALSE(config.is_valid());
  CHECK_THROWS_WITH(config.validate(), Catch::Contains("drive_profile") && Catch::Contains("got 7"));
  std::array<Frame, 3> frames{};
  CodecStatus status = CodecStatus::kOk;
  CHECK(can::encode_setpoints(config, hand_currents(3), frames, status) == 0);
  CHECK(status == CodecStatus::kOutOfRange);
}

TEST_CASE("phase-current encoding and decoding 1e5 times does not allocate", "[can][allocation][phase_current]") {
  const auto config = phase_current_config(4);
  auto command = hand_currents(4);
  std::array<Frame, 3> frames{};
  can::SetpointCommand accumulate;
  std::size_t ok = 0;
  clm::test::AllocationScope scope;
  for (int i = 0; i < 100000; ++i) {
    command.alive_counter = static_cast<std::uint8_t>(i);
    command.currents[0].ia_A = 1e-3 * (i % 1000);
    CodecStatus status = CodecStatus::kWrongId;
    ok += can::encode_setpoints(config, command, frames, status);
    for (const auto& frame : frames) ok += can::decode_setpoint_frame(config, frame, accumulate) == CodecStatus::kOk;
  }
  const std::size_t allocations = scope.allocations();
  CHECK(allocations == 0);
  CHECK(ok == 100000u * 6);
}
