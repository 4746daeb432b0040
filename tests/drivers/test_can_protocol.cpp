// The codec of drivers/can_protocol.hpp: identifiers, configuration, known
// byte layouts computed by hand, seeded random round trips, range ends,
// refusals that write nothing, and no allocation.

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

can::ProtocolConfig config_with(int coil_sets) {
  can::ProtocolConfig config;
  config.coil_sets = coil_sets;
  return config;
}

}  // namespace

// --- configuration and identifiers -----------------------------------------

TEST_CASE("protocol config defaults are drive node 1 and sensor node 2 with three coil sets and are valid", "[can]") {
  const can::ProtocolConfig config;
  CHECK(config.drive_node_id == 1);
  CHECK(config.force_sensor_node_id == 2);
  CHECK(config.coil_sets == 3);
  CHECK_NOTHROW(config.validate());
  CHECK(config.is_valid());
}

TEST_CASE("protocol config validation names the offending field and value", "[can]") {
  can::ProtocolConfig config;
  config.drive_node_id = 0;
  CHECK_THROWS_WITH(config.validate(), Catch::Contains("drive_node_id") && Catch::Contains("got 0"));
  CHECK_FALSE(config.is_valid());
  config.drive_node_id = 128;
  CHECK_THROWS_WITH(config.validate(), Catch::Contains("drive_node_id") && Catch::Contains("got 128"));

  config = {};
  config.force_sensor_node_id = 200;
  CHECK_THROWS_AS(config.validate(), std::invalid_argument);
  CHECK_THROWS_WITH(config.validate(), Catch::Contains("force_sensor_node_id") && Catch::Contains("got 200"));

  config = {};
  config.force_sensor_node_id = 1;
  CHECK_THROWS_WITH(config.validate(), Catch::Contains("force_sensor_node_id") && Catch::Contains("differ"));

  config = {};
  config.coil_sets = 5;
  CHECK_THROWS_WITH(config.validate(), Catch::Contains("coil_sets") && Catch::Contains("at most 4") &&
                                           Catch::Contains("got 5"));
  config.coil_sets = 0;
  CHECK_THROWS_WITH(config.validate(), Catch::Contains("coil_sets") && Catch::Contains("got 0"));
  for (int l = 1; l <= 4; ++l) CHECK_NOTHROW(config_with(l).validate());
}

TEST_CASE("COB-IDs are CANopen SYNC and TPDO1 and TPDO2 and RPDO1-3 plus the configured node IDs", "[can]") {
  const can::ProtocolConfig defaults;
  CHECK(can::kSyncId == 0x080);
  CHECK(can::drive_feedback_id(defaults) == 0x181);
  CHECK(can::drive_latch_id(defaults) == 0x281);
  CHECK(can::force_feedback_id(defaults) == 0x182);
  CHECK(can::setpoint_id(defaults, 0) == 0x201);
  CHECK(can::setpoint_id(defaults, 1) == 0x301);
  CHECK(can::setpoint_id(defaults, 2) == 0x401);
  const auto receive = can::daemon_receive_ids(defaults);
  REQUIRE(receive.view().size() == 3);
  CHECK(receive.view()[0] == 0x181);
  CHECK(receive.view()[1] == 0x281);
  CHECK(receive.view()[2] == 0x182);

  can::ProtocolConfig other;
  other.drive_node_id = 0x7F;
  other.force_sensor_node_id = 0x10;
  CHECK(can::drive_feedback_id(other) == 0x1FF);
  CHECK(can::drive_latch_id(other) == 0x2FF);
  CHECK(can::force_feedback_id(other) == 0x190);
  CHECK(can::setpoint_id(other, 0) == 0x27F);
  CHECK(can::setpoint_id(other, 1) == 0x37F);
  CHECK(can::setpoint_id(other, 2) == 0x47F);
}

TEST_CASE("an axis without a force sensor receives the drive's TPDO1 and TPDO2 alone and has no force frame", "[can]") {
  can::ProtocolConfig none;
  none.force_sensor_node_id = can::kNoForceSensor;
  CHECK_NOTHROW(none.validate());
  CHECK(none.is_valid());
  CHECK_FALSE(can::has_force_sensor(none));
  CHECK(can::has_force_sensor(can::ProtocolConfig{}));
  const auto receive = can::daemon_receive_ids(none);
  REQUIRE(receive.view().size() == 2);
  CHECK(receive.view()[0] == can::drive_feedback_id(none));
  CHECK(receive.view()[1] == can::drive_latch_id(none));
  // Node 0 is no node: no force frame is encoded, and a frame at 0x180 is not one.
  can::Frame frame;
  CHECK(can::encode_force_feedback(none, can::ForceFeedback{}, frame) == CodecStatus::kOutOfRange);
  can::Frame at_base;
  at_base.id = can::kTpdo1Base;
  at_base.dlc = can::kForceFeedbackDlc;
  can::ForceFeedback decoded;
  decoded.alive_counter = 42;
  CHECK(can::decode_force_feedback(none, at_base, decoded) == CodecStatus::kOutOfRange);
  CHECK(decoded.alive_counter == 42);
}

TEST_CASE("L coil sets need one RPDO for L=1 and two for L=2..3 and three for L=4", "[can]") {
  CHECK(can::setpoint_frame_count(0) == 0);
  CHECK(can::setpoint_frame_count(1) == 1);
  CHECK(can::setpoint_frame_count(2) == 2);
  CHECK(can::setpoint_frame_count(3) == 2);
  CHECK(can::setpoint_frame_count(4) == 3);
  CHECK(can::setpoint_frame_count(5) == 0);
}

TEST_CASE("codec status names", "[can]") {
  CHECK(std::string(can::to_string(CodecStatus::kOk)) == "ok");
  CHECK(std::string(can::to_string(CodecStatus::kWrongId)) == "wrong id");
  CHECK(std::string(can::to_string(CodecStatus::kWrongLength)) == "wrong length");
  CHECK(std::string(can::to_string(CodecStatus::kOutOfRange)) == "out of range");
  CHECK(std::string(can::to_string(CodecStatus::kNotFinite)) == "not finite");
}

// --- SYNC ---------------------------------------------------------------------

TEST_CASE("SYNC carries the counter 1..240 in one byte and round-trips it exactly", "[can][sync]") {
  for (int counter = 1; counter <= 240; ++counter) {
    Frame frame = sentinel_frame();
    REQUIRE(can::encode_sync(static_cast<std::uint8_t>(counter), frame) == CodecStatus::kOk);
    CHECK(same_frame(frame, frame_of(0x080, {static_cast<std::uint8_t>(counter)})));
    CHECK(frame.data[1] == 0);
    std::uint8_t decoded = 0;
    REQUIRE(can::decode_sync(frame, decoded) == CodecStatus::kOk);
    CHECK(decoded == counter);
  }
}

TEST_CASE("SYNC counter 0 and 241..255 are refused both ways and nothing is written", "[can][sync]") {
  for (int counter : {0, 241, 255}) {
    Frame frame = sentinel_frame();
    CHECK(can::encode_sync(static_cast<std::uint8_t>(counter), frame) == CodecStatus::kOutOfRange);
    CHECK(same_frame(frame, sentinel_frame()));
    std::uint8_t decoded = 77;
    CHECK(can::decode_sync(frame_of(0x080, {static_cast<std::uint8_t>(counter)}), decoded) == CodecStatus::kOutOfRange);
    CHECK(decoded == 77);
  }
}

TEST_CASE("SYNC decoding refuses another identifier or DLC", "[can][sync]") {
  std::uint8_t decoded = 77;
  CHECK(can::decode_sync(frame_of(0x081, {5}), decoded) == CodecStatus::kWrongId);
  CHECK(can::decode_sync(frame_of(0x080, {}), decoded) == CodecStatus::kWrongLength);
  CHECK(can::decode_sync(frame_of(0x080, {5, 0}), decoded) == CodecStatus::kWrongLength);
  CHECK(decoded == 77);
}

TEST_CASE("the SYNC counter counts 1..240 and wraps to 1", "[can][sync]") {
  CHECK(can::next_sync_counter(1) == 2);
  CHECK(can::next_sync_counter(239) == 240);
  CHECK(can::next_sync_counter(240) == 1);
  std::uint8_t counter = 1;
  for (int i = 0; i < 240; ++i) counter = can::next_sync_counter(counter);
  CHECK(counter == 1);
}

// --- drive feedback -------------------------------------------------------------

TEST_CASE("drive feedback has the hand-computed little-endian layout", "[can][drive]") {
  const can::ProtocolConfig config;
  // 0.123456789 m = 123456789 nm = 0x075BCD15; status enabled|end stop = 0x0011; alive 0x2A.
  Frame frame = sentinel_frame();
  REQUIRE(can::encode_drive_feedback(config, {0.123456789, 0x0011, 0x2A}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x181, {0x15, 0xCD, 0x5B, 0x07, 0x11, 0x00, 0x2A})));
  CHECK(frame.data[7] == 0);

  // -1 nm is 0xFFFFFFFF; fault|watchdog = 0x0006.
  REQUIRE(can::encode_drive_feedback(config, {-1e-9, 0x0006, 0xFF}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x181, {0xFF, 0xFF, 0xFF, 0xFF, 0x06, 0x00, 0xFF})));

  // The int32 ends: -2147483648 nm = 0x80000000, 2147483647 nm = 0x7FFFFFFF.
  REQUIRE(can::encode_drive_feedback(config, {-2.147483648, 0, 0}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x181, {0x00, 0x00, 0x00, 0x80, 0, 0, 0})));
  REQUIRE(can::encode_drive_feedback(config, {2.147483647, 0, 0}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x181, {0xFF, 0xFF, 0xFF, 0x7F, 0, 0, 0})));

  can::DriveFeedback decoded;
  REQUIRE(can::decode_drive_feedback(config, frame_of(0x181, {0x15, 0xCD, 0x5B, 0x07, 0x1F, 0x00, 0x2A}), decoded) ==
          CodecStatus::kOk);
  CHECK(decoded.position_m == 0.123456789);
  CHECK(decoded.status_word == 0x001F);
  CHECK(decoded.alive_counter == 0x2A);
}

TEST_CASE("drive feedback round-trips random positions within half a nanometre and integers exactly",
          "[can][drive][property]") {
  std::mt19937_64 random(1001);
  std::uniform_real_distribution<double> position(-2.147483648, 2.147483647);
  std::uniform_int_distribution<int> status_bits(0, 0x7F);
  std::uniform_int_distribution<int> alive(0, 255);
  can::ProtocolConfig config;
  config.drive_node_id = 9;
  config.force_sensor_node_id = 10;
  for (int i = 0; i < 100000; ++i) {
    const can::DriveFeedback sent{position(random), static_cast<std::uint16_t>(status_bits(random)),
                                  static_cast<std::uint8_t>(alive(random))};
    Frame frame;
    REQUIRE(can::encode_drive_feedback(config, sent, frame) == CodecStatus::kOk);
    REQUIRE(frame.id == 0x189);
    REQUIRE(frame.dlc == 7);
    can::DriveFeedback received;
    REQUIRE(can::decode_drive_feedback(config, frame, received) == CodecStatus::kOk);
    REQUIRE(std::abs(received.position_m - sent.position_m) <= 0.5e-9 * (1 + 1e-6));
    REQUIRE(received.status_word == sent.status_word);
    REQUIRE(received.alive_counter == sent.alive_counter);
  }
}

TEST_CASE("drive feedback refuses positions beyond int32 nm or not finite and reserved status bits and writes nothing",
          "[can][drive]") {
  const can::ProtocolConfig config;
  Frame frame = sentinel_frame();
  CHECK(can::encode_drive_feedback(config, {2.147483648, 0, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(can::encode_drive_feedback(config, {-2.147483649, 0, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(can::encode_drive_feedback(config, {1e300, 0, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(can::encode_drive_feedback(config, {kNaN, 0, 0}, frame) == CodecStatus::kNotFinite);
  CHECK(can::encode_drive_feedback(config, {kInf, 0, 0}, frame) == CodecStatus::kNotFinite);
  CHECK(can::encode_drive_feedback(config, {-kInf, 0, 0}, frame) == CodecStatus::kNotFinite);
  CHECK(can::encode_drive_feedback(config, {0.0, 0x0080, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(can::encode_drive_feedback(config, {0.0, 0x0100, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(can::encode_drive_feedback(config, {0.0, 0x8000, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(same_frame(frame, sentinel_frame()));
  // Just inside after rounding to the nearest nm.
  CHECK(can::encode_drive_feedback(config, {2.1474836474, 0, 0}, frame) == CodecStatus::kOk);
}

TEST_CASE("drive feedback decoding refuses a wrong identifier or DLC or a reserved status bit and writes nothing",
          "[can][drive]") {
  const can::ProtocolConfig config;
  const can::DriveFeedback before{0.5, 0x0001, 3};
  can::DriveFeedback decoded = before;
  CHECK(can::decode_drive_feedback(config, frame_of(0x182, {1, 2, 3, 4, 0, 0, 5}), decoded) == CodecStatus::kWrongId);
  CHECK(can::decode_drive_feedback(config, frame_of(0x181, {1, 2, 3, 4, 0, 0, 5, 0}), decoded) ==
        CodecStatus::kWrongLength);
  CHECK(can::decode_drive_feedback(config, frame_of(0x181, {1, 2, 3, 4, 0, 0}), decoded) == CodecStatus::kWrongLength);
  CHECK(can::decode_drive_feedback(config, frame_of(0x181, {1, 2, 3, 4, 0x80, 0, 5}), decoded) ==
        CodecStatus::kOutOfRange);
  CHECK(can::decode_drive_feedback(config, frame_of(0x181, {1, 2, 3, 4, 0xFF, 0, 5}), decoded) ==
        CodecStatus::kOutOfRange);
  CHECK(can::decode_drive_feedback(config, frame_of(0x181, {1, 2, 3, 4, 0, 0x01, 5}), decoded) ==
        CodecStatus::kOutOfRange);
  CHECK(decoded.position_m == before.position_m);
  CHECK(decoded.status_word == before.status_word);
  CHECK(decoded.alive_counter == before.alive_counter);
}

TEST_CASE("status bits 5 and 6 are the latch and the reference switch and round-trip, and bits 7..15 stay reserved",
          "[can][drive]") {
  CHECK(can::kStatusLatched == 0x0020);
  CHECK(can::kStatusReferenceSwitch == 0x0040);
  CHECK(can::kStatusReservedMask == 0xFF80);
  CHECK((can::kStatusReservedMask & (can::kStatusEnabled | can::kStatusFault | can::kStatusWatchdogExpired |
                                     can::kStatusCurrentLimited | can::kStatusEndStop | can::kStatusLatched |
                                     can::kStatusReferenceSwitch)) == 0);
  const can::ProtocolConfig config;
  Frame frame = sentinel_frame();
  REQUIRE(can::encode_drive_feedback(config, {0.0, 0x0061, 9}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x181, {0, 0, 0, 0, 0x61, 0x00, 9})));
  can::DriveFeedback decoded;
  REQUIRE(can::decode_drive_feedback(config, frame_of(0x181, {0, 0, 0, 0, 0x7F, 0x00, 9}), decoded) ==
          CodecStatus::kOk);
  CHECK(decoded.status_word == 0x007F);
  for (int bit = 7; bit < 16; ++bit) {
    INFO("status bit " << bit);
    const auto word = static_cast<std::uint16_t>(1u << bit);
    Frame refused = sentinel_frame();
    CHECK(can::encode_drive_feedback(config, {0.0, word, 0}, refused) == CodecStatus::kOutOfRange);
    CHECK(same_frame(refused, sentinel_frame()));
    const auto low = static_cast<std::uint8_t>(word & 0xFF), high = static_cast<std::uint8_t>(word >> 8);
    CHECK(can::decode_drive_feedback(config, frame_of(0x181, {0, 0, 0, 0, low, high, 0}), decoded) ==
          CodecStatus::kOutOfRange);
  }
}

TEST_CASE("drive_signals maps every status bit, the latch (bit 5) and the reference switch (bit 6) included",
          "[can][drive]") {
  const auto none = can::drive_signals(0);
  CHECK_FALSE(none.latched);
  CHECK_FALSE(none.reference_switch);
  const auto latched = can::drive_signals(can::kStatusLatched);
  CHECK(latched.latched);
  CHECK_FALSE(latched.reference_switch);
  CHECK_FALSE(latched.enabled);
  CHECK_FALSE(latched.end_stop);
  const auto at_switch = can::drive_signals(can::kStatusReferenceSwitch);
  CHECK(at_switch.reference_switch);
  CHECK_FALSE(at_switch.latched);
  CHECK_FALSE(at_switch.end_stop);
  const auto all = can::drive_signals(0x007F);
  CHECK(all.enabled);
  CHECK(all.fault);
  CHECK(all.watchdog_expired);
  CHECK(all.current_limited);
  CHECK(all.end_stop);
  CHECK(all.latched);
  CHECK(all.reference_switch);
  // Each bit maps to its own signal alone.
  const auto enabled_only = can::drive_signals(can::kStatusEnabled | can::kStatusEndStop);
  CHECK_FALSE(enabled_only.latched);
  CHECK_FALSE(enabled_only.reference_switch);
}

// --- drive latch -------------------------------------------------------------------

TEST_CASE("drive latch is TPDO2 with the hand-computed little-endian layout", "[can][latch]") {
  const can::ProtocolConfig config;
  CHECK(can::kTpdo2Base == 0x280);
  CHECK(can::kDriveLatchDlc == 5);
  // 0.123456789 m = 0x075BCD15 nm; count 0x2A.
  Frame frame = sentinel_frame();
  REQUIRE(can::encode_drive_latch(config, {0.123456789, 0x2A}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x281, {0x15, 0xCD, 0x5B, 0x07, 0x2A})));
  CHECK(frame.data[5] == 0);
  CHECK(frame.data[7] == 0);
  // -1 nm is 0xFFFFFFFF; the int32 ends as in the drive feedback.
  REQUIRE(can::encode_drive_latch(config, {-1e-9, 0xFF}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x281, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF})));
  REQUIRE(can::encode_drive_latch(config, {-2.147483648, 0}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x281, {0x00, 0x00, 0x00, 0x80, 0x00})));
  REQUIRE(can::encode_drive_latch(config, {2.147483647, 1}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x281, {0xFF, 0xFF, 0xFF, 0x7F, 0x01})));

  can::DriveLatch decoded;
  REQUIRE(can::decode_drive_latch(config, frame_of(0x281, {0x15, 0xCD, 0x5B, 0x07, 0x2A}), decoded) ==
          CodecStatus::kOk);
  CHECK(decoded.position_m == 0.123456789);
  CHECK(decoded.latch_count == 0x2A);

  can::ProtocolConfig other;
  other.drive_node_id = 0x7F;
  other.force_sensor_node_id = 0x10;
  REQUIRE(can::encode_drive_latch(other, {0.0, 3}, frame) == CodecStatus::kOk);
  CHECK(frame.id == 0x2FF);
}

TEST_CASE("drive latch round-trips random and negative positions within half a nanometre and the count exactly",
          "[can][latch][property]") {
  std::mt19937_64 random(1004);
  std::uniform_real_distribution<double> position(-2.147483648, 2.147483647);
  can::ProtocolConfig config;
  config.drive_node_id = 9;
  config.force_sensor_node_id = can::kNoForceSensor;  // the latch does not depend on the sensor
  std::uint8_t count = 250;                            // wraps 255 → 0 within the first frames
  int negative = 0;
  for (int i = 0; i < 100000; ++i) {
    const can::DriveLatch sent{position(random), count};
    negative += sent.position_m < 0.0;
    Frame frame;
    REQUIRE(can::encode_drive_latch(config, sent, frame) == CodecStatus::kOk);
    REQUIRE(frame.id == 0x289);
    REQUIRE(frame.dlc == 5);
    can::DriveLatch received;
    REQUIRE(can::decode_drive_latch(config, frame, received) == CodecStatus::kOk);
    REQUIRE(std::abs(received.position_m - sent.position_m) <= 0.5e-9 * (1 + 1e-6));
    REQUIRE(received.latch_count == sent.latch_count);
    ++count;
  }
  CHECK(negative > 40000);
  // The count wraps 255 → 0 as a uint8 on the wire.
  Frame frame;
  can::DriveLatch received;
  REQUIRE(can::encode_drive_latch(config, {-0.5, 255}, frame) == CodecStatus::kOk);
  REQUIRE(can::decode_drive_latch(config, frame, received) == CodecStatus::kOk);
  CHECK(received.latch_count == 255);
  CHECK(received.position_m == -0.5);
  REQUIRE(can::encode_drive_latch(config, {-0.5, static_cast<std::uint8_t>(received.latch_count + 1)}, frame) ==
          CodecStatus::kOk);
  REQUIRE(can::decode_drive_latch(config, frame, received) == CodecStatus::kOk);
  CHECK(received.latch_count == 0);
}

TEST_CASE("drive latch encoding refuses positions beyond int32 nm or not finite and writes nothing", "[can][latch]") {
  const can::ProtocolConfig config;
  Frame frame = sentinel_frame();
  CHECK(can::encode_drive_latch(config, {2.147483648, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(can::encode_drive_latch(config, {-2.147483649, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(can::encode_drive_latch(config, {1e300, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(can::encode_drive_latch(config, {-1e300, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(can::encode_drive_latch(config, {kNaN, 0}, frame) == CodecStatus::kNotFinite);
  CHECK(can::encode_drive_latch(config, {kInf, 0}, frame) == CodecStatus::kNotFinite);
  CHECK(can::encode_drive_latch(config, {-kInf, 0}, frame) == CodecStatus::kNotFinite);
  can::ProtocolConfig invalid;
  invalid.drive_node_id = 0;
  CHECK(can::encode_drive_latch(invalid, {0.0, 0}, frame) == CodecStatus::kOutOfRange);
  CHECK(same_frame(frame, sentinel_frame()));
  // Just inside after rounding to the nearest nm, as the drive feedback.
  CHECK(can::encode_drive_latch(config, {2.1474836474, 0}, frame) == CodecStatus::kOk);
  CHECK(can::encode_drive_latch(config, {-2.1474836484, 0}, frame) == CodecStatus::kOk);
}

TEST_CASE("drive latch decoding refuses a wrong identifier or DLC and writes nothing", "[can][latch]") {
  const can::ProtocolConfig config;
  const can::DriveLatch before{0.25, 17};
  can::DriveLatch decoded = before;
  // The drive's TPDO1 and another node's TPDO2 are not its latch frame.
  CHECK(can::decode_drive_latch(config, frame_of(0x181, {1, 2, 3, 4, 5}), decoded) == CodecStatus::kWrongId);
  CHECK(can::decode_drive_latch(config, frame_of(0x282, {1, 2, 3, 4, 5}), decoded) == CodecStatus::kWrongId);
  CHECK(can::decode_drive_latch(config, frame_of(0x281, {1, 2, 3, 4}), decoded) == CodecStatus::kWrongLength);
  CHECK(can::decode_drive_latch(config, frame_of(0x281, {1, 2, 3, 4, 5, 0}), decoded) == CodecStatus::kWrongLength);
  CHECK(can::decode_drive_latch(config, frame_of(0x281, {}), decoded) == CodecStatus::kWrongLength);
  can::ProtocolConfig invalid;
  invalid.coil_sets = 0;
  CHECK(can::decode_drive_latch(invalid, frame_of(0x281, {1, 2, 3, 4, 5}), decoded) == CodecStatus::kOutOfRange);
  CHECK(decoded.position_m == before.position_m);
  CHECK(decoded.latch_count == before.latch_count);
  // And the drive feedback's decoder does not take a latch frame.
  can::DriveFeedback feedback;
  CHECK(can::decode_drive_feedback(config, frame_of(0x281, {1, 2, 3, 4, 5}), feedback) == CodecStatus::kWrongId);
}

// --- force feedback ---------------------------------------------------------------

TEST_CASE("force feedback has the hand-computed little-endian layout", "[can][force]") {
  const can::ProtocolConfig config;
  // F_y -1 N = -1000 mN = 0xFFFC18 (int24); F_x 2.5 N = 250 = 0x00FA; T_z -0.5 N·m = -500 = 0xFE0C; alive 7.
  Frame frame = sentinel_frame();
  REQUIRE(can::encode_force_feedback(config, {clm::Wrench(-1.0, 2.5, -0.5), 7}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x182, {0x18, 0xFC, 0xFF, 0xFA, 0x00, 0x0C, 0xFE, 0x07})));

  // The ends: F_y 8388.607 N = 0x7FFFFF, F_x -327.68 N = 0x8000, T_z 32.767 N·m = 0x7FFF.
  REQUIRE(can::encode_force_feedback(config, {clm::Wrench(8388.607, -327.68, 32.767), 0}, frame) == CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x182, {0xFF, 0xFF, 0x7F, 0x00, 0x80, 0xFF, 0x7F, 0x00})));
  REQUIRE(can::encode_force_feedback(config, {clm::Wrench(-8388.608, 327.67, -32.768), 255}, frame) ==
          CodecStatus::kOk);
  CHECK(same_frame(frame, frame_of(0x182, {0x00, 0x00, 0x80, 0xFF, 0x7F, 0x00, 0x80, 0xFF})));

  can::ForceFeedback decoded;
  REQUIRE(can::decode_force_feedback(config, frame_of(0x182, {0x18, 0xFC, 0xFF, 0xFA, 0x00, 0x0C, 0xFE, 0x07}),
                                     decoded) == CodecStatus::kOk);
  CHECK(decoded.wrench[0] == -1.0);
  CHECK(decoded.wrench[1] == 2.5);
  CHECK(decoded.wrench[2] == -0.5);
  CHECK(decoded.alive_counter == 7);
}

TEST_CASE("force feedback round-trips random wrenches within half an LSB per component", "[can][force][property]") {
  std::mt19937_64 random(1002);
  std::uniform_real_distribution<double> force_y(-8388.608, 8388.607);
  std::uniform_real_distribution<double> force_x(-327.68, 327.67);
  std::uniform_real_distribution<double> torque_z(-32.768, 32.767);
  std::uniform_int_distribution<int> alive(0, 255);
  const can::ProtocolConfig config;
  for (int i = 0; i < 100000; ++i) {
    const can::ForceFeedback sent{clm::Wrench(force_y(random), force_x(random), torque_z(random)),
                                  static_cast<std::uint8_t>(alive(random))};
    Frame frame;
    REQUIRE(can::encode_force_feedback(config, sent, frame) == CodecStatus::kOk);
    can::ForceFeedback received;
    REQUIRE(can::decode_force_feedback(config, frame, received) == CodecStatus::kOk);
    REQUIRE(std::abs(received.wrench[0] - sent.wrench[0]) <= 0.5e-3 * (1 + 1e-6));
    REQUIRE(std::abs(received.wrench[1] - sent.wrench[1]) <= 0.5e-2 * (1 + 1e-6));
    REQUIRE(std::abs(received.wrench[2] - sent.wrench[2]) <= 0.5e-3 * (1 + 1e-6));
    REQUIRE(received.alive_counter == sent.alive_counter);
  }
}

TEST_CASE("force feedback refuses each component out of range or not finite and writes nothing", "[can][force]") {
  const can::ProtocolConfig config;
  Frame frame = sentinel_frame();
  const std::array<clm::Wrench, 6> out_of_range{
      clm::Wrench(8388.6085, 0, 0), clm::Wrench(-8388.609, 0, 0), clm::Wrench(0, 327.68, 0),
      clm::Wrench(0, -327.69, 0),   clm::Wrench(0, 0, 32.768),    clm::Wrench(0, 0, -32.769)};
  for (const auto& wrench : out_of_range) {
    INFO(wrench.transpose());
    CHECK(can::encode_force_feedback(config, {wrench, 0}, frame) == CodecStatus::kOutOfRange);
  }
  for (int component = 0; component < 3; ++component) {
    clm::Wrench wrench = clm::Wrench::Zero();
    wrench[component] = kNaN;
    CHECK(can::encode_force_feedback(config, {wrench, 0}, frame) == CodecStatus::kNotFinite);
    wrench[component] = -kInf;
    CHECK(can::encode_force_feedback(config, {wrench, 0}, frame) == CodecStatus::kNotFinite);
  }
  CHECK(same_frame(frame, sentinel_frame()));
}

TEST_CASE("force feedback decoding refuses a wrong identifier or DLC and writes nothing", "[can][force]") {
  const can::ProtocolConfig config;
  can::ForceFeedback decoded{clm::Wrench(1, 2, 3), 4};
  CHECK(can::decode_force_feedback(config, frame_of(0x181, {0, 0, 0, 0, 0, 0, 0, 0}), decoded) ==
        CodecStatus::kWrongId);
  CHECK(can::decode_force_feedback(config, frame_of(0x182, {0, 0, 0, 0, 0, 0, 0}), decoded) ==
        CodecStatus::kWrongLength);
  CHECK(decoded.wrench == clm::Wrench(1, 2, 3));
  CHECK(decoded.alive_counter == 4);
}

// --- setpoints ----------------------------------------------------------------------

namespace {

can::SetpointCommand hand_command(int coil_sets) {
  can::SetpointCommand command;
  command.enable = true;
  command.clear_fault = false;
  command.alive_counter = 0x10;
  command.coil_sets = coil_sets;
  command.setpoints[0] = {100.0, -0.5};       // 4000 = 0x0FA0, -5000 = 0xEC78
  command.setpoints[1] = {-0.025, 3.2767};    // -1 = 0xFFFF, 32767 = 0x7FFF
  command.setpoints[2] = {819.175, -3.2768};  // 32767 = 0x7FFF, -32768 = 0x8000
  command.setpoints[3] = {0.0, 0.0001};       // 0, 1
  return command;
}

}  // namespace

TEST_CASE("setpoints for L=4 have the hand-computed layouts of RPDO1 and RPDO2 and RPDO3", "[can][setpoint]") {
  std::array<Frame, 4> frames{sentinel_frame(), sentinel_frame(), sentinel_frame(), sentinel_frame()};
  CodecStatus status = CodecStatus::kWrongId;
  REQUIRE(can::encode_setpoints(config_with(4), hand_command(4), frames, status) == 3);
  CHECK(status == CodecStatus::kOk);
  CHECK(same_frame(frames[0], frame_of(0x201, {0x01, 0x10, 0xA0, 0x0F, 0x78, 0xEC})));
  CHECK(same_frame(frames[1], frame_of(0x301, {0xFF, 0xFF, 0xFF, 0x7F, 0xFF, 0x7F, 0x00, 0x80})));
  CHECK(same_frame(frames[2], frame_of(0x401, {0x00, 0x00, 0x01, 0x00})));
  CHECK(same_frame(frames[3], sentinel_frame()));
}

TEST_CASE("only the RPDOs L needs are sent and for L=2 the coil set 3 fields are zero", "[can][setpoint]") {
  std::array<Frame, 3> frames{};
  CodecStatus status = CodecStatus::kWrongId;

  frames.fill(sentinel_frame());
  REQUIRE(can::encode_setpoints(config_with(1), hand_command(1), frames, status) == 1);
  CHECK(same_frame(frames[0], frame_of(0x201, {0x01, 0x10, 0xA0, 0x0F, 0x78, 0xEC})));
  CHECK(same_frame(frames[1], sentinel_frame()));

  frames.fill(sentinel_frame());
  REQUIRE(can::encode_setpoints(config_with(2), hand_command(2), frames, status) == 2);
  CHECK(same_frame(frames[1], frame_of(0x301, {0xFF, 0xFF, 0xFF, 0x7F, 0x00, 0x00, 0x00, 0x00})));
  CHECK(same_frame(frames[2], sentinel_frame()));

  frames.fill(sentinel_frame());
  REQUIRE(can::encode_setpoints(config_with(3), hand_command(3), frames, status) == 2);
  CHECK(same_frame(frames[1], frame_of(0x301, {0xFF, 0xFF, 0xFF, 0x7F, 0xFF, 0x7F, 0x00, 0x80})));
  CHECK(same_frame(frames[2], sentinel_frame()));

  // Control byte: clear fault alone is 0x02, both bits 0x03.
  auto command = hand_command(1);
  command.enable = false;
  command.clear_fault = true;
  REQUIRE(can::encode_setpoints(config_with(1), command, frames, status) == 1);
  CHECK(frames[0].data[0] == 0x02);
  command.enable = true;
  REQUIRE(can::encode_setpoints(config_with(1), command, frames, status) == 1);
  CHECK(frames[0].data[0] == 0x03);
}

TEST_CASE("the control byte's bits 2 and 3 arm the latch and choose the reference switch, and round-trip",
          "[can][setpoint][latch]") {
  CHECK(can::kControlArmLatch == 0x04);
  CHECK(can::kControlLatchOnSwitch == 0x08);
  CHECK(can::kControlReservedMask == 0xF0);
  const can::SetpointCommand defaults;
  CHECK_FALSE(defaults.arm_latch);
  CHECK_FALSE(defaults.latch_on_switch);
  std::array<Frame, 3> frames{};
  CodecStatus status = CodecStatus::kWrongId;
  for (int bits = 0; bits < 16; ++bits) {
    INFO("control bits " << bits);
    auto command = hand_command(1);
    command.enable = (bits & 1) != 0;
    command.clear_fault = (bits & 2) != 0;
    command.arm_latch = (bits & 4) != 0;
    command.latch_on_switch = (bits & 8) != 0;
    REQUIRE(can::encode_setpoints(config_with(1), command, frames, status) == 1);
    CHECK(frames[0].data[0] == bits);
    can::SetpointCommand received;
    REQUIRE(can::decode_setpoint_frame(config_with(1), frames[0], received) == CodecStatus::kOk);
    CHECK(received.enable == command.enable);
    CHECK(received.clear_fault == command.clear_fault);
    CHECK(received.arm_latch == command.arm_latch);
    CHECK(received.latch_on_switch == command.latch_on_switch);
  }
  // Hand-made RPDO1 with arm latch and latch on switch: 0x0C.
  can::SetpointCommand received;
  REQUIRE(can::decode_setpoint_frame(config_with(1), frame_of(0x201, {0x0C, 0x10, 0xA0, 0x0F, 0x78, 0xEC}), received) ==
          CodecStatus::kOk);
  CHECK_FALSE(received.enable);
  CHECK_FALSE(received.clear_fault);
  CHECK(received.arm_latch);
  CHECK(received.latch_on_switch);
}

TEST_CASE("setpoints round-trip random values for every L within half an LSB", "[can][setpoint][property]") {
  std::mt19937_64 random(1003);
  std::uniform_real_distribution<double> magnitude(-819.2, 819.175);
  std::uniform_real_distribution<double> delta(-3.2768, 3.2767);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int l = 1; l <= 4; ++l) {
    const auto config = config_with(l);
    for (int i = 0; i < 25000; ++i) {
      can::SetpointCommand sent;
      sent.coil_sets = l;
      sent.enable = byte(random) % 2 == 1;
      sent.clear_fault = byte(random) % 2 == 1;
      sent.arm_latch = byte(random) % 2 == 1;
      sent.latch_on_switch = byte(random) % 2 == 1;
      sent.alive_counter = static_cast<std::uint8_t>(byte(random));
      for (int k = 0; k < l; ++k) sent.setpoints[static_cast<std::size_t>(k)] = {magnitude(random), delta(random)};
      std::array<Frame, 3> frames{};
      CodecStatus status = CodecStatus::kWrongId;
      const std::size_t count = can::encode_setpoints(config, sent, frames, status);
      REQUIRE(status == CodecStatus::kOk);
      REQUIRE(count == can::setpoint_frame_count(l));

      can::SetpointCommand received;
      for (std::size_t f = 0; f < count; ++f) {
        REQUIRE(can::decode_setpoint_frame(config, frames[f], received) == CodecStatus::kOk);
      }
      REQUIRE(received.coil_sets == l);
      REQUIRE(received.enable == sent.enable);
      REQUIRE(received.clear_fault == sent.clear_fault);
      REQUIRE(received.arm_latch == sent.arm_latch);
      REQUIRE(received.latch_on_switch == sent.latch_on_switch);
      REQUIRE(received.alive_counter == sent.alive_counter);
      for (std::size_t k = 0; k < static_cast<std::size_t>(l); ++k) {
        REQUIRE(std::abs(received.setpoints[k].magnitude_N - sent.setpoints[k].magnitude_N) <= 0.0125 * (1 + 1e-6));
        REQUIRE(std::abs(received.setpoints[k].delta_rad - sent.setpoints[k].delta_rad) <= 0.5e-4 * (1 + 1e-6));
      }
    }
  }
}

TEST_CASE("setpoint encoding refuses a bad value in any coil set and writes no frame at all", "[can][setpoint]") {
  const auto config = config_with(4);
  const std::array<Frame, 3> untouched{sentinel_frame(), sentinel_frame(), sentinel_frame()};
  for (std::size_t set = 0; set < 4; ++set) {
    for (const auto& [bad, expected] : std::vector<std::pair<clm::DriveSetpoint, CodecStatus>>{
             {{819.2, 0.0}, CodecStatus::kOutOfRange},
             {{-819.225, 0.0}, CodecStatus::kOutOfRange},
             {{0.0, 3.2768}, CodecStatus::kOutOfRange},
             {{0.0, -3.2769}, CodecStatus::kOutOfRange},
             {{kNaN, 0.0}, CodecStatus::kNotFinite},
             {{0.0, kInf}, CodecStatus::kNotFinite}}) {
      INFO("coil set " << set + 1 << ": " << bad.magnitude_N << " N, " << bad.delta_rad << " rad");
      auto command = hand_command(4);
      command.setpoints[set] = bad;
      auto frames = untouched;
      CodecStatus status = CodecStatus::kOk;
      CHECK(can::encode_setpoints(config, command, frames, status) == 0);
      CHECK(status == expected);
      for (std::size_t f = 0; f < 3; ++f) CHECK(same_frame(frames[f], untouched[f]));
    }
  }
}

TEST_CASE("setpoint encoding refuses a command for another L or a span too short", "[can][setpoint]") {
  std::array<Frame, 3> frames{sentinel_frame(), sentinel_frame(), sentinel_frame()};
  CodecStatus status = CodecStatus::kOk;
  CHECK(can::encode_setpoints(config_with(3), hand_command(4), frames, status) == 0);
  CHECK(status == CodecStatus::kOutOfRange);
  CHECK(can::encode_setpoints(config_with(4), hand_command(4), std::span<Frame>(frames).first(2), status) == 0);
  CHECK(status == CodecStatus::kWrongLength);
  CHECK(can::encode_setpoints(config_with(5), hand_command(5), frames, status) == 0);
  CHECK(status == CodecStatus::kOutOfRange);
  for (const auto& frame : frames) CHECK(same_frame(frame, sentinel_frame()));
  // Values of coil sets beyond L are not sent, so they are not checked either.
  auto command = hand_command(1);
  command.setpoints[1].magnitude_N = kNaN;
  CHECK(can::encode_setpoints(config_with(1), command, frames, status) == 1);
  CHECK(status == CodecStatus::kOk);
}

TEST_CASE("setpoint decoding refuses RPDOs that L does not use and wrong DLCs and reserved control bits",
          "[can][setpoint]") {
  can::SetpointCommand accumulate;
  accumulate.alive_counter = 99;
  const auto before = accumulate;
  const auto unchanged = [&] {
    return accumulate.alive_counter == before.alive_counter && accumulate.coil_sets == before.coil_sets &&
           accumulate.setpoints[0].magnitude_N == 0.0 && accumulate.setpoints[3].magnitude_N == 0.0;
  };
  CHECK(can::decode_setpoint_frame(config_with(3), frame_of(0x401, {0, 0, 1, 0}), accumulate) ==
        CodecStatus::kWrongId);
  CHECK(can::decode_setpoint_frame(config_with(1), frame_of(0x301, {1, 0, 0, 0, 0, 0, 0, 0}), accumulate) ==
        CodecStatus::kWrongId);
  CHECK(can::decode_setpoint_frame(config_with(4), frame_of(0x202, {1, 2, 3, 4, 5, 6}), accumulate) ==
        CodecStatus::kWrongId);
  CHECK(can::decode_setpoint_frame(config_with(4), frame_of(0x201, {1, 2, 3, 4, 5}), accumulate) ==
        CodecStatus::kWrongLength);
  CHECK(can::decode_setpoint_frame(config_with(4), frame_of(0x301, {1, 2, 3, 4}), accumulate) ==
        CodecStatus::kWrongLength);
  CHECK(can::decode_setpoint_frame(config_with(4), frame_of(0x401, {1, 2, 3, 4, 0, 0, 0, 0}), accumulate) ==
        CodecStatus::kWrongLength);
  for (const std::uint8_t reserved : std::initializer_list<std::uint8_t>{0x10, 0x20, 0x40, 0x80, 0xF0, 0xFF}) {
    INFO("control byte " << static_cast<int>(reserved));
    CHECK(can::decode_setpoint_frame(config_with(4), frame_of(0x201, {reserved, 2, 3, 4, 5, 6}), accumulate) ==
          CodecStatus::kOutOfRange);
  }
  CHECK(can::decode_setpoint_frame(config_with(4), frame_of(0x201, {0x80, 2, 3, 4, 5, 6}), accumulate) ==
        CodecStatus::kOutOfRange);
  // For L = 2 a non-zero coil set 3 means the daemon and the drive disagree on L.
  CHECK(can::decode_setpoint_frame(config_with(2), frame_of(0x301, {1, 0, 0, 0, 0, 0, 0, 1}), accumulate) ==
        CodecStatus::kOutOfRange);
  CHECK(unchanged());
  CHECK(can::decode_setpoint_frame(config_with(2), frame_of(0x301, {1, 0, 0, 0, 0, 0, 0, 0}), accumulate) ==
        CodecStatus::kOk);
  CHECK(accumulate.setpoints[1].magnitude_N == 0.025);
  CHECK(accumulate.coil_sets == 2);
}

TEST_CASE("setpoint decoding reads the hand-computed RPDO bytes", "[can][setpoint]") {
  can::SetpointCommand accumulate;
  const auto config = config_with(4);
  REQUIRE(can::decode_setpoint_frame(config, frame_of(0x201, {0x03, 0x10, 0xA0, 0x0F, 0x78, 0xEC}), accumulate) ==
          CodecStatus::kOk);
  REQUIRE(can::decode_setpoint_frame(config, frame_of(0x301, {0xFF, 0xFF, 0xFF, 0x7F, 0xFF, 0x7F, 0x00, 0x80}),
                                     accumulate) == CodecStatus::kOk);
  REQUIRE(can::decode_setpoint_frame(config, frame_of(0x401, {0x00, 0x00, 0x01, 0x00}), accumulate) ==
          CodecStatus::kOk);
  CHECK(accumulate.enable);
  CHECK(accumulate.clear_fault);
  CHECK(accumulate.alive_counter == 0x10);
  CHECK(accumulate.coil_sets == 4);
  CHECK(accumulate.setpoints[0].magnitude_N == 100.0);
  CHECK(accumulate.setpoints[0].delta_rad == -0.5);
  CHECK(accumulate.setpoints[1].magnitude_N == -0.025);
  CHECK(accumulate.setpoints[1].delta_rad == 3.2767);
  CHECK(accumulate.setpoints[2].magnitude_N == 819.175);
  CHECK(accumulate.setpoints[2].delta_rad == -3.2768);
  CHECK(accumulate.setpoints[3].magnitude_N == 0.0);
  CHECK(accumulate.setpoints[3].delta_rad == 0.0001);
}

// --- describe and allocation ------------------------------------------------------------

TEST_CASE("describe prints identifier and DLC and bytes like candump", "[can]") {
  CHECK(can::describe(frame_of(0x181, {0x15, 0xCD, 0x5B, 0x07, 0x11, 0x00, 0x2A})) ==
        "0x181 [7] 15 CD 5B 07 11 00 2A");
  CHECK(can::describe(frame_of(0x080, {0x01})) == "0x080 [1] 01");
  CHECK(can::describe(frame_of(0x7FF, {})) == "0x7FF [0]");
}

TEST_CASE("encoding and decoding every frame 1e5 times does not allocate", "[can][allocation]") {
  const auto config = config_with(4);
  auto command = hand_command(4);
  std::array<Frame, 3> setpoint_frames{};
  Frame sync;
  Frame drive;
  Frame force;
  Frame latch;
  can::DriveLatch drive_latch;
  can::SetpointCommand accumulate;
  can::DriveFeedback drive_feedback;
  can::ForceFeedback force_feedback;
  std::uint8_t counter = 1;
  std::size_t ok = 0;
  clm::test::AllocationScope scope;
  for (int i = 0; i < 100000; ++i) {
    command.alive_counter = static_cast<std::uint8_t>(i);
    command.setpoints[0].magnitude_N = 1e-3 * (i % 1000);
    CodecStatus status = CodecStatus::kWrongId;
    ok += can::encode_setpoints(config, command, setpoint_frames, status);
    for (const auto& frame : setpoint_frames) ok += can::decode_setpoint_frame(config, frame, accumulate) == CodecStatus::kOk;
    ok += can::encode_sync(counter, sync) == CodecStatus::kOk;
    ok += can::decode_sync(sync, counter) == CodecStatus::kOk;
    counter = can::next_sync_counter(counter);
    ok += can::encode_drive_feedback(config, {1e-6 * i, can::kStatusEnabled, static_cast<std::uint8_t>(i)}, drive) ==
          CodecStatus::kOk;
    ok += can::decode_drive_feedback(config, drive, drive_feedback) == CodecStatus::kOk;
    force_feedback.wrench = clm::Wrench(1e-3 * i, 0.5, -0.25);
    ok += can::encode_force_feedback(config, force_feedback, force) == CodecStatus::kOk;
    ok += can::decode_force_feedback(config, force, force_feedback) == CodecStatus::kOk;
    ok += can::encode_drive_latch(config, {-1e-6 * i, static_cast<std::uint8_t>(i)}, latch) == CodecStatus::kOk;
    ok += can::decode_drive_latch(config, latch, drive_latch) == CodecStatus::kOk;
  }
  const std::size_t allocations = scope.allocations();
  CHECK(allocations == 0);
  CHECK(ok == 100000u * (3 + 3 + 8));
}
