// The pre-decode check of LCM datagrams (daemon/telemetry/wire_check.hpp):
// each hand-written layout agrees with lcm-gen's encoding of random messages,
// every malformed length, range or number is refused before decode, and the
// datagram that crashed the daemon is refused with the field named.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "daemon/telemetry/wire_check.hpp"
#include "support/hostile_datagram.hpp"

using namespace clm::telemetry;
using clm::test::encode_command;

namespace {

template <typename Message>
std::vector<std::uint8_t> encode(const Message& message) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(message.getEncodedSize()));
  REQUIRE(message.encode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()));
  return bytes;
}

struct Random {
  std::mt19937_64 engine{20261124};
  double number() { return std::uniform_real_distribution<double>(-1e3, 1e3)(engine); }
  int integer(int low, int high) { return std::uniform_int_distribution<int>(low, high)(engine); }
  std::string text(int max_length) {
    std::string s(static_cast<std::size_t>(integer(0, max_length)), ' ');
    for (char& c : s) c = static_cast<char>(integer(0x20, 0x7e));
    return s;
  }
};

clm_lcm::servo_state_t random_state(Random& random) {
  clm_lcm::servo_state_t s{};
  s.utime = random.integer(0, 1 << 30);
  s.cycle = random.integer(0, 1 << 30);
  for (double* d : {&s.t_s, &s.r_m, &s.r_dot_m_per_s, &s.r_ddot_m_per_s2, &s.y_m, &s.e_m, &s.F_star_N, &s.u_fb_N,
                    &s.u_ff_N, &s.Fy_star_N, &s.Fx_star_N, &s.Tz_star_Nm, &s.Fy_N, &s.Fx_N, &s.Tz_Nm, &s.delta_rad,
                    &s.current_square_sum_A2, &s.program_time_s}) {
    *d = random.number();
  }
  s.commutation = static_cast<std::int8_t>(random.integer(0, 5));
  s.coil_set = static_cast<std::int8_t>(random.integer(0, 8));
  s.coil_sets = static_cast<std::int8_t>(random.integer(0, 8));
  for (auto* v : {&s.magnitude_N, &s.setpoint_delta_rad, &s.ia_A, &s.ib_A}) {
    v->resize(static_cast<std::size_t>(s.coil_sets));
    for (double& d : *v) d = random.number();
  }
  s.damping_engaged = random.integer(0, 1) != 0;
  s.force_limited = random.integer(0, 1) != 0;
  s.state = static_cast<std::int8_t>(random.integer(0, 2));
  s.program_running = random.integer(0, 1) != 0;
  s.drive_profile = static_cast<std::int8_t>(random.integer(0, 1));
  return s;
}

clm_lcm::servo_command_t random_command(Random& random) {
  clm_lcm::servo_command_t c{};
  c.utime = random.integer(0, 1 << 30);
  c.sequence = random.integer(0, 1 << 30);
  c.axis = random.text(32);
  c.session = random.integer(0, 1 << 30);
  c.client = random.integer(0, 1 << 30);
  c.command = static_cast<std::int8_t>(random.integer(1, 13));
  c.target_m = random.number();
  c.velocity_m_per_s = random.number();
  c.acceleration_m_per_s2 = random.number();
  c.jerk_m_per_s3 = random.number();
  c.program = random.text(255);
  c.commutation = static_cast<std::int8_t>(random.integer(0, 5));
  c.coil_set = static_cast<std::int8_t>(random.integer(0, 8));
  c.delta_rad = random.number();
  c.path = random.text(255);
  return c;
}

clm_lcm::servo_status_t random_status(Random& random) {
  clm_lcm::servo_status_t s{};
  s.utime = random.integer(0, 1 << 30);
  s.state = static_cast<std::int8_t>(random.integer(0, 2));
  s.fault = static_cast<std::int16_t>(random.integer(0, 300));
  s.fault_reason = random.text(300);
  s.fault_cycle = random.integer(-1, 1 << 30);
  s.commutation = static_cast<std::int8_t>(random.integer(0, 5));
  s.axis = random.text(32);
  s.session = random.integer(1, 1 << 30);
  s.calibration_file = random.text(300);
  s.calibration_sha256 = random.text(64);
  s.pgnn_model_file = random.text(300);
  s.pgnn_model_sha256 = random.text(64);
  s.spline_model_file = random.text(300);
  s.feedforward_file = random.text(300);
  s.feedforward_sha256 = random.text(64);
  s.control_client = random.integer(0, 1 << 30);
  s.control_lease_remaining_s = random.number();
  s.commands_refused_replayed = random.integer(0, 1 << 30);
  for (double* d : {&s.wakeup_latency_p50_s, &s.wakeup_latency_p99_s, &s.wakeup_latency_max_s, &s.compute_time_p50_s,
                    &s.compute_time_p99_s, &s.compute_time_max_s, &s.program_time_s}) {
    *d = random.number();
  }
  s.overruns = random.integer(0, 1 << 30);
  for (std::size_t j = 0; j < 31; ++j) {
    s.wakeup_latency_histogram[j] = random.integer(0, 1 << 30);
    s.compute_time_histogram[j] = random.integer(0, 1 << 30);
  }
  s.bus_state = static_cast<std::int8_t>(random.integer(-1, 3));
  s.program_running = random.integer(0, 1) != 0;
  return s;
}

template <typename Message>
void require_accepted_and_decoded(const Message& message) {
  const auto bytes = encode(message);
  Message decoded;
  REQUIRE(decode_checked(std::span<const std::uint8_t>(bytes), decoded) == "");
  REQUIRE(encode(decoded) == bytes);
  // Every proper prefix is refused before decode.
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    INFO("prefix of " << n << " bytes");
    REQUIRE(check_wire(wire_layout(static_cast<const Message*>(nullptr)),
                       std::span<const std::uint8_t>(bytes.data(), n)) != "");
  }
  // So is one byte too many.
  auto longer = bytes;
  longer.push_back(0);
  REQUIRE(check_wire(wire_layout(static_cast<const Message*>(nullptr)), longer) != "");
}

std::string check_command(const std::vector<std::uint8_t>& bytes) {
  return check_wire(wire_layout(static_cast<const clm_lcm::servo_command_t*>(nullptr)), bytes);
}

}  // namespace

TEST_CASE("every layout agrees with lcm-gen's encoding of random messages, and every truncation is refused",
          "[wire]") {
  Random random;
  for (int trial = 0; trial < 40; ++trial) {
    require_accepted_and_decoded(random_state(random));
    require_accepted_and_decoded(random_command(random));
    require_accepted_and_decoded(random_status(random));
    clm_lcm::servo_event_t event{};
    event.code = static_cast<std::int16_t>(random.integer(-300, 300));
    event.severity = static_cast<std::int8_t>(random.integer(0, 3));
    event.text = random.text(200);
    require_accepted_and_decoded(event);
    clm_lcm::servo_command_ack_t ack{};
    ack.sequence = random.integer(0, 1000);
    ack.axis = random.text(32);
    ack.client = random.integer(0, 1000);
    ack.accepted = random.integer(0, 1) != 0;
    ack.text = random.text(200);
    require_accepted_and_decoded(ack);
  }
}

TEST_CASE("a command with program length -2^31 is refused before decode, naming the field", "[wire]") {
  const auto bytes = clm::test::program_length_min_int32_datagram();
  clm_lcm::servo_command_t command;
  const std::string reason = decode_checked(std::span<const std::uint8_t>(bytes), command);
  CHECK_THAT(reason, Catch::Contains("servo_command_t.program") && Catch::Contains("-2147483648"));
}

TEST_CASE("string lengths of zero, beyond the datagram or over the limit are refused", "[wire]") {
  clm_lcm::servo_command_t command{};
  command.command = clm_lcm::servo_command_t::RUN_PROGRAM;
  command.program = "abc";
  const auto good = encode_command(command);
  REQUIRE(check_command(good) == "");
  const auto with_length = [&](std::uint32_t length) {
    auto bytes = good;
    for (int i = 0; i < 4; ++i) {
      bytes[clm::test::kCommandProgramLengthOffset + static_cast<std::size_t>(i)] =
          static_cast<std::uint8_t>(length >> (24 - 8 * i));
    }
    return bytes;
  };
  CHECK_THAT(check_command(with_length(0)), Catch::Contains("below 1"));
  CHECK_THAT(check_command(with_length(0xffffffffu)), Catch::Contains("below 1"));
  CHECK_THAT(check_command(with_length(200)), Catch::Contains("runs past"));
  CHECK_THAT(check_command(with_length(3)), Catch::Contains("NUL"));  // 'c' where the NUL should be

  command.program = std::string(256, 'x');
  CHECK_THAT(check_command(encode_command(command)), Catch::Contains("over the limit"));
  command.program = std::string("a\nb");
  CHECK_THAT(check_command(encode_command(command)), Catch::Contains("control character"));
}

TEST_CASE("enum ranges, booleans and non-finite numbers are refused before decode", "[wire]") {
  clm_lcm::servo_command_t command{};
  command.command = clm_lcm::servo_command_t::MOVE_TO;
  REQUIRE(check_command(encode_command(command)) == "");
  command.command = 0;
  CHECK_THAT(check_command(encode_command(command)), Catch::Contains("servo_command_t.command"));
  command.command = clm_lcm::servo_command_t::HOME + 1;  // one past the last kind
  CHECK_THAT(check_command(encode_command(command)), Catch::Contains("servo_command_t.command"));
  command.command = clm_lcm::servo_command_t::MOVE_TO;
  for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity()}) {
    command.target_m = bad;
    CHECK_THAT(check_command(encode_command(command)), Catch::Contains("target_m") && Catch::Contains("finite"));
  }

  clm_lcm::servo_state_t state{};
  state.coil_sets = 2;
  for (auto* v : {&state.magnitude_N, &state.setpoint_delta_rad, &state.ia_A, &state.ib_A}) v->assign(2, 0.0);
  auto bytes = encode(state);
  const auto& layout = wire_layout(static_cast<const clm_lcm::servo_state_t*>(nullptr));
  REQUIRE(check_wire(layout, bytes) == "");
  // coil_sets is the byte after hash, 2 int64, 15 doubles, 2 int8 and a double.
  const std::size_t coil_sets_offset = 8 + 2 * 8 + 15 * 8 + 2 + 8;
  REQUIRE(bytes[coil_sets_offset] == 2);
  bytes[coil_sets_offset] = 0xff;  // −1: lcm-gen would resize the arrays to SIZE_MAX
  CHECK_THAT(check_wire(layout, bytes), Catch::Contains("coil_sets"));
  bytes[coil_sets_offset] = 9;
  CHECK_THAT(check_wire(layout, bytes), Catch::Contains("coil_sets"));

  // A measured force may be NaN (no sensor frame); a demand may not.
  state.Fy_N = std::numeric_limits<double>::quiet_NaN();
  CHECK(check_wire(layout, encode(state)) == "");
  state.F_star_N = std::numeric_limits<double>::quiet_NaN();
  CHECK_THAT(check_wire(layout, encode(state)), Catch::Contains("F_star_N"));
  // drive_profile, the last byte before the 32 of the mac, is 0 or 1 (DRIVE_PROFILE_*).
  state.F_star_N = 0.0;
  state.drive_profile = clm_lcm::servo_state_t::DRIVE_PROFILE_PHASE_CURRENT;
  bytes = encode(state);
  REQUIRE(check_wire(layout, bytes) == "");
  const std::size_t drive_profile_offset = bytes.size() - 1 - 32;
  REQUIRE(bytes[drive_profile_offset] == 1);
  bytes[drive_profile_offset] = 2;
  CHECK_THAT(check_wire(layout, bytes), Catch::Contains("drive_profile"));
  // The mac's bytes may hold any value; the mac ends the message.
  bytes[drive_profile_offset] = 1;
  for (std::size_t i = bytes.size() - 32; i < bytes.size(); ++i) bytes[i] = 0xff;
  CHECK(check_wire(layout, bytes) == "");
  bytes.pop_back();
  CHECK_THAT(check_wire(layout, bytes), Catch::Contains("mac"));

  // A histogram count is 0 or more.
  clm_lcm::servo_status_t status{};
  const auto& status_layout = wire_layout(static_cast<const clm_lcm::servo_status_t*>(nullptr));
  REQUIRE(check_wire(status_layout, encode(status)) == "");
  status.compute_time_histogram[5] = -1;
  CHECK_THAT(check_wire(status_layout, encode(status)), Catch::Contains("compute_time_histogram[5]"));

  clm_lcm::servo_command_ack_t ack{};
  auto ack_bytes = encode(ack);
  ack_bytes[8 + 16 + 5 + 16] = 2;  // boolean `accepted` (after an empty axis) must be 0 or 1
  CHECK_THAT(check_wire(wire_layout(static_cast<const clm_lcm::servo_command_ack_t*>(nullptr)), ack_bytes),
             Catch::Contains("accepted"));
}

TEST_CASE("another type's datagram is refused by its hash", "[wire]") {
  clm_lcm::servo_command_ack_t ack{};
  const auto bytes = encode(ack);
  CHECK_THAT(check_command(bytes), Catch::Contains("hash"));
}
