// A real LCM round trip over UDP multicast on this host (label `lcm`). When
// multicast does not work here, these tests fail and say so: they never pass
// without having sent anything.
#include <catch2/catch.hpp>
#include <lcm/lcm-cpp.hpp>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <thread>

#include "config/sha256.hpp"
#include "daemon/telemetry/lcm_datagram.hpp"
#include "daemon/telemetry/message_mac.hpp"
#include "daemon/telemetry/wire_check.hpp"
#include "support/signed_lcm.hpp"
#include "telemetry/telemetry_samples.hpp"

using namespace clm::telemetry;

namespace {

// A port of its own per test process, so parallel runs and a daemon on the
// default port 7667 do not hear each other.
std::string test_url() {
  return "udpm://239.255.76.67:" + std::to_string(7700 + ::getpid() % 2000) + "?ttl=0";
}

constexpr const char* kNoMulticast =
    "LCM over UDP multicast is unavailable on this machine (%s). The test cannot run; it does not pass silently. "
    "On Linux a loopback route usually fixes it: `sudo ip route add 224.0.0.0/4 dev lo` and `sudo ip link set lo "
    "multicast on`; or exclude these tests with `ctest -LE lcm`.";

std::string no_multicast(const std::string& what) {
  char buffer[1024];
  std::snprintf(buffer, sizeof(buffer), kNoMulticast, what.c_str());
  return buffer;
}

/// The operators' key of these tests.
const clm::HmacSha256& test_key() {
  static const clm::HmacSha256 key = clm::test::key_of("clm-servo test key, 32 bytes at least");
  return key;
}

/// A publisher's settings on `url` with the test key.
TelemetryConfig keyed_config(const std::string& url) {
  TelemetryConfig config;
  config.lcm_url = url;
  config.key = test_key();
  return config;
}

/// Publishes `command` with the mac of the test key, as clm ctl does.
int publish_command(lcm::LCM& lcm, const clm_lcm::servo_command_t& command) {
  return clm::test::publish_signed(lcm, kCommandChannel, command, &test_key());
}

/// Keeps the bytes of every message of one channel.
struct RawCollector {
  void on_message(const lcm::ReceiveBuffer* buffer, const std::string&) {
    const auto* bytes = static_cast<const std::uint8_t*>(buffer->data);
    messages.emplace_back(bytes, bytes + buffer->data_size);
  }
  std::vector<std::vector<std::uint8_t>> messages;
};

/// Collects the messages of one channel.
template <typename Message>
class Collector {
 public:
  void on_message(const lcm::ReceiveBuffer*, const std::string&, const Message* message) { messages.push_back(*message); }
  std::vector<Message> messages;
};

/// Handles `subscriber` until `done()` or `timeout`; true if done.
template <typename Done>
bool handle_until(lcm::LCM& subscriber, Done done, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    subscriber.handleTimeout(20);
  }
  return true;
}

}  // namespace

TEST_CASE("A state pushed by the cycle arrives over udpm multicast with every field equal", "[telemetry][lcm]") {
  const std::string url = test_url();
  lcm::LCM subscriber(url);
  if (!subscriber.good()) FAIL(no_multicast("cannot open " + url));
  Collector<clm_lcm::servo_state_t> states;
  Collector<clm_lcm::servo_status_t> statuses;
  subscriber.subscribe(kStateChannel, &Collector<clm_lcm::servo_state_t>::on_message, &states);
  subscriber.subscribe(kStatusChannel, &Collector<clm_lcm::servo_status_t>::on_message, &statuses);

  const TelemetryConfig config = keyed_config(url);
  std::optional<TelemetryPublisher> publisher;
  try {
    publisher.emplace(config);
  } catch (const std::runtime_error& e) {
    FAIL(no_multicast(e.what()));
  }
  publisher->start();
  const auto sample = clm::test::make_state(4242, 4);
  const auto status = clm::test::make_status();
  // Datagrams may be lost; send again until one arrives (at most 5 times).
  bool received = false;
  for (int attempt = 0; attempt < 5 && !received; ++attempt) {
    REQUIRE(publisher->push_state(sample));
    REQUIRE(publisher->push_status(status));
    received = handle_until(
        subscriber, [&] { return !states.messages.empty() && !statuses.messages.empty(); },
        std::chrono::milliseconds(1000));
  }
  publisher->stop();
  if (!received) {
    FAIL(no_multicast("published on " + url + " but nothing came back within 5 s; publish failures: " +
                      std::to_string(publisher->counters().publish_failures)));
  }
  clm::test::check_state(sample, states.messages.front());
  clm::test::check_status(status, statuses.messages.front());
  CHECK(statuses.messages.front().telemetry_dropped == 0);
}

TEST_CASE("Commands sent over udpm multicast reach poll_command, an empty path is refused with an ack, a too-long "
          "one (failing the wire check) without one",
          "[telemetry][lcm]") {
  const std::string url = test_url();
  lcm::LCM operator_side(url);
  if (!operator_side.good()) FAIL(no_multicast("cannot open " + url));
  Collector<clm_lcm::servo_command_ack_t> acks;
  operator_side.subscribe(kCommandAckChannel, &Collector<clm_lcm::servo_command_ack_t>::on_message, &acks);

  const TelemetryConfig config = keyed_config(url);
  std::optional<TelemetryPublisher> publisher;
  try {
    publisher.emplace(config);
  } catch (const std::runtime_error& e) {
    FAIL(no_multicast(e.what()));
  }
  publisher->start();

  clm_lcm::servo_command_t move{};
  move.utime = wall_clock_utime();
  move.sequence = 1001;
  move.command = clm_lcm::servo_command_t::MOVE_TO;
  move.target_m = 0.025;
  move.velocity_m_per_s = 0.2;
  move.acceleration_m_per_s2 = 5.0;
  move.jerk_m_per_s3 = 500.0;
  clm_lcm::servo_command_t load{};
  load.utime = wall_clock_utime();
  load.sequence = 1002;
  load.command = clm_lcm::servo_command_t::LOAD_MODEL;
  load.path = "";  // well-formed on the wire, refused by to_command
  clm_lcm::servo_command_t too_long = load;
  too_long.sequence = 1003;
  too_long.path = "/" + std::string(400, 'x');  // beyond the wire layout's 255 bytes: no ack, counted malformed

  // The real-time side polls; resend until the command is taken (datagrams may be lost).
  clm::servo::Command command;
  bool taken = false;
  for (int attempt = 0; attempt < 5 && !taken; ++attempt) {
    REQUIRE(publish_command(operator_side, move) == 0);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(1);
    while (!(taken = publisher->poll_command(command)) && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  if (!taken) FAIL(no_multicast("a command published on " + url + " never reached the publisher"));
  CHECK(command.sequence == 1001);
  CHECK(command.kind == clm::servo::CommandKind::kMoveTo);
  CHECK(command.target_m == 0.025);
  CHECK(command.limits.velocity_m_per_s == 0.2);
  CHECK(command.limits.acceleration_m_per_s2 == 5.0);
  CHECK(command.limits.jerk_m_per_s3 == 500.0);

  bool refused = false;
  for (int attempt = 0; attempt < 5 && !refused; ++attempt) {
    REQUIRE(publish_command(operator_side, load) == 0);
    refused = handle_until(
        operator_side, [&] { return !acks.messages.empty(); }, std::chrono::milliseconds(1000));
  }
  REQUIRE(refused);
  const std::int64_t malformed_before = publisher->counters().commands_malformed;
  bool counted = false;
  for (int attempt = 0; attempt < 5 && !counted; ++attempt) {
    REQUIRE(publish_command(operator_side, too_long) == 0);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(1);
    while (!(counted = publisher->counters().commands_malformed > malformed_before) &&
           std::chrono::steady_clock::now() < deadline) {
      operator_side.handleTimeout(10);
    }
  }
  handle_until(operator_side, [] { return false; }, std::chrono::milliseconds(100));  // an ack would come by now
  publisher->stop();
  CHECK(counted);
  CHECK(acks.messages.front().sequence == 1002);
  CHECK_FALSE(acks.messages.front().accepted);
  CHECK(acks.messages.front().text == "path is empty");
  for (const auto& ack : acks.messages) CHECK(ack.sequence != 1003);
  while (publisher->poll_command(command)) CHECK(command.sequence == 1001);  // resent duplicates only
}

TEST_CASE("A fragment claiming 2^28 bytes is dropped unread and counted, the next command still arrives",
          "[telemetry][lcm][datagram]") {
  const std::string url = test_url();
  const TelemetryConfig config = keyed_config(url);
  std::optional<TelemetryPublisher> publisher;
  try {
    publisher.emplace(config);
  } catch (const std::runtime_error& e) {
    FAIL(no_multicast(e.what()));
  }
  publisher->start();
  lcm::LCM operator_side(url);
  if (!operator_side.good()) FAIL(no_multicast("cannot open " + url));
  // A raw fragment: LC03, sequence, payload size 2^28 - 1, offset 0, fragment 0 of 4097, channel, 1000 bytes.
  std::vector<std::uint8_t> fragment{0x4c, 0x43, 0x30, 0x33, 0, 0, 0, 1, 0x0f, 0xff, 0xff, 0xff, 0, 0, 0, 0, 0, 0, 0x10, 0x01};
  for (const char c : std::string(kCommandChannel)) fragment.push_back(static_cast<std::uint8_t>(c));
  fragment.push_back(0);
  fragment.resize(fragment.size() + 1000, 0xab);
  const UdpmAddress address = parse_udpm_url(url);
  const int sender = ::socket(AF_INET, SOCK_DGRAM, 0);
  REQUIRE(sender >= 0);
  sockaddr_in group{};
  group.sin_family = AF_INET;
  group.sin_port = htons(address.port);
  ::inet_pton(AF_INET, address.group.c_str(), &group.sin_addr);
  const unsigned char ttl = 0;
  ::setsockopt(sender, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
  constexpr int kFragments = 50;
  for (int k = 0; k < kFragments; ++k) {
    REQUIRE(::sendto(sender, fragment.data(), fragment.size(), 0, reinterpret_cast<const sockaddr*>(&group),
                     sizeof group) == static_cast<ssize_t>(fragment.size()));
  }
  ::close(sender);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (publisher->counters().datagrams_dropped < kFragments && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  INFO("datagrams_dropped " << publisher->counters().datagrams_dropped << ", fragments sent " << kFragments);
  CHECK(publisher->counters().datagrams_dropped == kFragments);
  clm_lcm::servo_command_t enable{};
  enable.utime = wall_clock_utime();
  enable.sequence = 7;
  enable.command = clm_lcm::servo_command_t::ENABLE;
  clm::servo::Command command;
  bool taken = false;
  for (int attempt = 0; attempt < 5 && !taken; ++attempt) {
    REQUIRE(publish_command(operator_side, enable) == 0);
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(1);
    while (!(taken = publisher->poll_command(command)) && std::chrono::steady_clock::now() < until) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  publisher->stop();
  CHECK(taken);
  CHECK(command.sequence == 7);
}

TEST_CASE("Over udpm every message published carries the mac of the key, a command without it is refused as "
          "unauthenticated, a stop without it is taken",
          "[telemetry][lcm][mac]") {
  const std::string url = test_url();
  lcm::LCM operator_side(url);
  if (!operator_side.good()) FAIL(no_multicast("cannot open " + url));
  RawCollector acks, statuses;
  operator_side.subscribe(kCommandAckChannel, &RawCollector::on_message, &acks);
  operator_side.subscribe(kStatusChannel, &RawCollector::on_message, &statuses);
  std::optional<TelemetryPublisher> publisher;
  try {
    publisher.emplace(keyed_config(url));
  } catch (const std::runtime_error& e) {
    FAIL(no_multicast(e.what()));
  }
  publisher->start();
  clm_lcm::servo_command_t enable{};
  enable.utime = wall_clock_utime();
  enable.sequence = 11;
  enable.client = 5;
  enable.command = clm_lcm::servo_command_t::ENABLE;
  bool answered = false;
  for (int attempt = 0; attempt < 5 && !answered; ++attempt) {
    REQUIRE(clm::test::publish_signed(operator_side, kCommandChannel, enable, nullptr) == 0);
    answered = handle_until(operator_side, [&] { return !acks.messages.empty(); }, std::chrono::milliseconds(1000));
  }
  REQUIRE(answered);
  clm_lcm::servo_command_ack_t ack;
  REQUIRE(decode_checked(std::span<const std::uint8_t>(acks.messages.front()), ack).empty());
  CHECK(ack.sequence == 11);
  CHECK_FALSE(ack.accepted);
  CHECK(ack.text.rfind("unauthenticated", 0) == 0);
  CHECK(verify_encoded(test_key(), kCommandAckChannel, acks.messages.front()));
  CHECK_FALSE(verify_encoded(test_key(), kStatusChannel, acks.messages.front()));  // keyed to its channel
  CHECK_FALSE(verify_encoded(clm::test::key_of("another key, also of 32 bytes or more"), kCommandAckChannel,
                             acks.messages.front()));
  CHECK(publisher->counters().commands_unauthenticated >= 1);
  clm::servo::Command command;
  CHECK_FALSE(publisher->poll_command(command));

  clm_lcm::servo_command_t stop = enable;
  stop.sequence = 12;
  stop.command = clm_lcm::servo_command_t::STOP;
  bool taken = false;
  for (int attempt = 0; attempt < 5 && !taken; ++attempt) {
    REQUIRE(clm::test::publish_signed(operator_side, kCommandChannel, stop, nullptr) == 0);
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(1);
    while (!(taken = publisher->poll_command(command)) && std::chrono::steady_clock::now() < until) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  CHECK(taken);
  CHECK(command.kind == clm::servo::CommandKind::kStop);

  bool heard = false;
  for (int attempt = 0; attempt < 5 && !heard; ++attempt) {
    REQUIRE(publisher->push_status(clm::test::make_status()));
    heard = handle_until(operator_side, [&] { return !statuses.messages.empty(); }, std::chrono::milliseconds(1000));
  }
  publisher->stop();
  REQUIRE(heard);
  std::vector<std::uint8_t> status = statuses.messages.front();
  CHECK(verify_encoded(test_key(), kStatusChannel, status));
  status[20] ^= 1;  // one bit of the status changed: the mac no longer holds
  CHECK_FALSE(verify_encoded(test_key(), kStatusChannel, status));
}
