// Worst-case bus load of the cycle schedule, against a hand calculation.
//
// Standard data frame with n data bytes: 47 + 8n bits without stuffing (SOF,
// 11-bit ID, RTR, IDE, r0, 4-bit DLC, data, 15-bit CRC, CRC delimiter, ACK slot
// and delimiter, 7-bit EOF, 3-bit interframe space); the 34 + 8n bits from SOF
// to the end of the CRC are stuffed, worst case ⌊(34 + 8n − 1)/4⌋ stuff bits.
//   n = 1 (SYNC):           55 + ⌊41/4⌋ = 55 + 10 =  65
//   n = 4 (RPDO3):          79 + ⌊65/4⌋ = 79 + 16 =  95
//   n = 5 (drive TPDO2):    87 + ⌊73/4⌋ = 87 + 18 = 105
//   n = 6 (RPDO1):          95 + ⌊81/4⌋ = 95 + 20 = 115
//   n = 7 (drive TPDO1):   103 + ⌊89/4⌋ = 103 + 22 = 125
//   n = 8 (force, RPDO2):  111 + ⌊97/4⌋ = 111 + 24 = 135
// Cycle: SYNC + drive + force = 325 bits, plus RPDO1 (L ≥ 1) 115, RPDO2 (L ≥ 2)
// 135, RPDO3 (L = 4) 95: L=1 440, L=2 575, L=3 575, L=4 670 bits. The drive
// latch (TPDO2) is an event frame, at most one per arming: not in the cycle.

#include <catch2/catch.hpp>

#include <limits>
#include <stdexcept>

#include "drivers/can/can_protocol.hpp"

namespace can = clm::can;

namespace {
can::ProtocolConfig config_with(int coil_sets) {
  can::ProtocolConfig config;
  config.coil_sets = coil_sets;
  return config;
}
}  // namespace

TEST_CASE("worst-case frame lengths match the hand count with bit stuffing", "[can][bus_load]") {
  CHECK(can::worst_case_frame_bits(0) == 47 + 8);  // 47 fixed + ⌊33/4⌋ = 8 stuff bits
  CHECK(can::worst_case_frame_bits(1) == 65);
  CHECK(can::worst_case_frame_bits(4) == 95);
  CHECK(can::worst_case_frame_bits(5) == 105);
  CHECK(can::worst_case_frame_bits(can::kDriveLatchDlc) == 105);
  CHECK(can::worst_case_frame_bits(6) == 115);
  CHECK(can::worst_case_frame_bits(7) == 125);
  CHECK(can::worst_case_frame_bits(8) == 135);
}

TEST_CASE("cycle schedule bits for L = 1..4 match the hand count", "[can][bus_load]") {
  CHECK(can::cycle_bits(config_with(1)) == 440);
  CHECK(can::cycle_bits(config_with(2)) == 575);
  CHECK(can::cycle_bits(config_with(3)) == 575);
  CHECK(can::cycle_bits(config_with(4)) == 670);
}

TEST_CASE("the drive latch is an event frame: the cycle schedule leaves it out and it fits the one period it is in",
          "[can][bus_load]") {
  for (int l = 1; l <= 4; ++l) {
    // Its 105 bits would make the cyclic sums above anything but 440/575/575/670.
    const std::uint32_t with_latch = can::cycle_bits(config_with(l)) + can::worst_case_frame_bits(can::kDriveLatchDlc);
    CHECK(with_latch <= 1000u);  // 1 ms at 1 Mbit/s
  }
  CHECK(can::cycle_bits(config_with(4)) + can::worst_case_frame_bits(can::kDriveLatchDlc) == 775);
}

TEST_CASE("without a force sensor the cycle schedule is one DLC-8 frame (135 bits) shorter", "[can][bus_load]") {
  for (int l = 1; l <= 4; ++l) {
    can::ProtocolConfig none = config_with(l);
    none.force_sensor_node_id = can::kNoForceSensor;
    CHECK(can::cycle_bits(none) == can::cycle_bits(config_with(l)) - 135);
  }
  can::ProtocolConfig none = config_with(3);
  none.force_sensor_node_id = can::kNoForceSensor;
  CHECK(can::bus_load(none, 1e6, 1000.0) == Approx(0.440).epsilon(1e-12));  // (575 - 135) bits at 1 kHz
}

TEST_CASE("bus load at 1 kHz on 1 Mbit/s is 44.0 / 57.5 / 57.5 / 67.0 percent for L = 1..4", "[can][bus_load]") {
  CHECK(can::bus_load(config_with(1), 1e6, 1000.0) == Approx(0.440).epsilon(1e-12));
  CHECK(can::bus_load(config_with(2), 1e6, 1000.0) == Approx(0.575).epsilon(1e-12));
  CHECK(can::bus_load(config_with(3), 1e6, 1000.0) == Approx(0.575).epsilon(1e-12));
  CHECK(can::bus_load(config_with(4), 1e6, 1000.0) == Approx(0.670).epsilon(1e-12));
  CHECK(can::bus_load(config_with(3), 500e3, 1000.0) == Approx(1.150).epsilon(1e-12));
}

TEST_CASE("L = 3 at 1 kHz on 1 Mbit/s passes the 70 percent check and 4 kHz is refused with the load", "[can][bus_load]") {
  CHECK(can::check_bus_load(config_with(3), 1e6, 1000.0) == Approx(0.575));
  CHECK_NOTHROW(can::check_bus_load(config_with(4), 1e6, 1000.0));
  CHECK_THROWS_AS(can::check_bus_load(config_with(3), 1e6, 4000.0), std::invalid_argument);
  // 575 bits · 4000 Hz / 1e6 bit/s = 230 %.
  CHECK_THROWS_WITH(can::check_bus_load(config_with(3), 1e6, 4000.0),
                    Catch::Contains("230.0 %") && Catch::Contains("70.0 %") && Catch::Contains("575"));
  // 440 bits at 2 kHz = 88 %: refused at 70 %, allowed with a 90 % limit.
  CHECK_THROWS_WITH(can::check_bus_load(config_with(1), 1e6, 2000.0), Catch::Contains("88.0 %"));
  CHECK_NOTHROW(can::check_bus_load(config_with(1), 1e6, 2000.0, 0.90));
}

TEST_CASE("bus load refuses invalid rates and limits and configurations with the field named", "[can][bus_load]") {
  const can::ProtocolConfig config;
  CHECK_THROWS_WITH(can::bus_load(config, 0.0, 1000.0), Catch::Contains("bitrate_bps"));
  CHECK_THROWS_WITH(can::bus_load(config, std::numeric_limits<double>::quiet_NaN(), 1000.0),
                    Catch::Contains("bitrate_bps"));
  CHECK_THROWS_WITH(can::bus_load(config, 1e6, -1.0), Catch::Contains("cycle_rate_hz"));
  CHECK_THROWS_WITH(can::bus_load(config, 1e6, std::numeric_limits<double>::infinity()),
                    Catch::Contains("cycle_rate_hz"));
  CHECK_THROWS_WITH(can::check_bus_load(config, 1e6, 1000.0, 1.5), Catch::Contains("limit"));
  CHECK_THROWS_WITH(can::bus_load(config_with(5), 1e6, 1000.0), Catch::Contains("coil_sets"));
}
