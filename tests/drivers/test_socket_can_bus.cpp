// SocketCanBus. Construction errors and error-frame decoding run everywhere;
// the tests that need a CAN interface use a vcan one (CLM_TEST_CAN_INTERFACE,
// default vcan0) and skip with a warning when the kernel has no SocketCAN
// (EAFNOSUPPORT, as on CI's and developers' machines) or the interface is
// missing. A QEMU guest with vcan runs them.

#include <catch2/catch.hpp>

#include <linux/can.h>
#include <linux/can/error.h>
#include <net/if.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>

#include "drivers/socket_can_bus.hpp"
#include "support/allocation_counter.hpp"

using clm::drivers::BusState;
using clm::drivers::ReceivedFrame;
using clm::drivers::SocketCanBus;

namespace {

/// 0 if this kernel can open a raw CAN socket, else the errno of socket(), checked directly.
int socketcan_error() {
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return errno;
  ::close(fd);
  return 0;
}

bool kernel_has_socketcan() { return socketcan_error() == 0; }

std::string test_interface() {
  const char* name = std::getenv("CLM_TEST_CAN_INTERFACE");
  return name != nullptr && *name != '\0' ? name : "vcan0";
}

/// Skips the calling test case (WARN + false) unless a vcan interface is usable.
bool vcan_available() {
  if (!kernel_has_socketcan()) {
    WARN("skipped: this kernel has no SocketCAN (socket(AF_CAN) fails with EAFNOSUPPORT)");
    return false;
  }
  if (::if_nametoindex(test_interface().c_str()) == 0) {
    WARN("skipped: no CAN interface " << test_interface() << " (ip link add dev vcan0 type vcan; ip link set up vcan0)");
    return false;
  }
  return true;
}

std::int64_t monotonic_ns() {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

clm::can::Frame frame_of(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  clm::can::Frame frame;
  frame.id = id;
  frame.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (const auto byte : bytes) frame.data[i++] = byte;
  return frame;
}

}  // namespace

TEST_CASE("opening a CAN interface that does not exist throws naming it or says the kernel has no SocketCAN",
          "[can][socketcan]") {
  const std::array<std::uint32_t, 2> ids{0x181, 0x182};
  const std::string name = "clmnocan7";
  try {
    SocketCanBus bus(name, ids);
    FAIL("SocketCanBus opened the non-existent interface " << name);
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    INFO(message);
    CHECK(message.rfind("socketcan: ", 0) == 0);
    CHECK(message.find("'" + name + "'") != std::string::npos);
    const int socket_errno = socketcan_error();
    if (socket_errno == 0) {
      CHECK(message.find("No such device") != std::string::npos);
    } else {
      REQUIRE(socket_errno == EAFNOSUPPORT);
      CHECK(message.find("Address family not supported by protocol") != std::string::npos);
      CHECK(message.find("(this kernel has no SocketCAN)") != std::string::npos);
    }
  }
}

TEST_CASE("SocketCanBus refuses an interface name longer than IFNAMSIZ and extended receive IDs", "[can][socketcan]") {
  const std::array<std::uint32_t, 1> ids{0x181};
  const std::string long_name(IFNAMSIZ, 'c');
  CHECK_THROWS_AS(SocketCanBus(long_name, ids), std::runtime_error);
  CHECK_THROWS_WITH(SocketCanBus(long_name, ids), Catch::Contains(long_name) && Catch::Contains("1..15 characters"));
  const std::array<std::uint32_t, 2> extended{0x181, 0x800};
  CHECK_THROWS_AS(SocketCanBus("vcan0", extended), std::invalid_argument);
  CHECK_THROWS_WITH(SocketCanBus("vcan0", extended), Catch::Contains("2048") && Catch::Contains("vcan0"));
}

TEST_CASE("error frames set the bus state to bus-off or active after restart or passive or warning and back to active", "[can][socketcan]") {
  using clm::drivers::bus_state_after_error;
  CHECK(bus_state_after_error(BusState::kActive, CAN_ERR_BUSOFF, 0) == BusState::kBusOff);
  CHECK(bus_state_after_error(BusState::kBusOff, CAN_ERR_RESTARTED, 0) == BusState::kActive);
  CHECK(bus_state_after_error(BusState::kActive, CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING) == BusState::kErrorWarning);
  CHECK(bus_state_after_error(BusState::kActive, CAN_ERR_CRTL, CAN_ERR_CRTL_RX_WARNING) == BusState::kErrorWarning);
  CHECK(bus_state_after_error(BusState::kErrorWarning, CAN_ERR_CRTL, CAN_ERR_CRTL_RX_PASSIVE) ==
        BusState::kErrorPassive);
  CHECK(bus_state_after_error(BusState::kActive, CAN_ERR_CRTL | CAN_ERR_PROT,
                              CAN_ERR_CRTL_TX_PASSIVE | CAN_ERR_CRTL_RX_WARNING) == BusState::kErrorPassive);
  // Falling back: the kernel reports the new, lower state.
  CHECK(bus_state_after_error(BusState::kErrorPassive, CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING) ==
        BusState::kErrorWarning);
  CHECK(bus_state_after_error(BusState::kErrorPassive, CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE) == BusState::kActive);
  // Errors that say nothing about the state leave it alone.
  CHECK(bus_state_after_error(BusState::kErrorWarning, CAN_ERR_PROT | CAN_ERR_ACK, 0) == BusState::kErrorWarning);
  CHECK(bus_state_after_error(BusState::kErrorPassive, CAN_ERR_CRTL, CAN_ERR_CRTL_RX_OVERFLOW) ==
        BusState::kErrorPassive);
  CHECK(bus_state_after_error(BusState::kActive, CAN_ERR_LOSTARB | CAN_ERR_TX_TIMEOUT, 0) == BusState::kActive);
  // Bus-off is left only by a restart (or the controller reporting error-active).
  CHECK(bus_state_after_error(BusState::kBusOff, CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE) == BusState::kBusOff);
  CHECK(bus_state_after_error(BusState::kBusOff, CAN_ERR_RESTARTED | CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING) ==
        BusState::kErrorWarning);
}

TEST_CASE("bus state names", "[can][socketcan]") {
  CHECK(std::string(clm::drivers::to_string(BusState::kActive)) == "active");
  CHECK(std::string(clm::drivers::to_string(BusState::kErrorWarning)) == "error warning");
  CHECK(std::string(clm::drivers::to_string(BusState::kErrorPassive)) == "error passive");
  CHECK(std::string(clm::drivers::to_string(BusState::kBusOff)) == "bus off");
}

// --- on a vcan interface (skipped without SocketCAN) -------------------------------

TEST_CASE("on vcan a frame sent by one socket arrives at another with a monotonic kernel timestamp",
          "[can][socketcan][vcan]") {
  if (!vcan_available()) return;
  const std::array<std::uint32_t, 1> node_ids{clm::can::kSyncId};
  const std::array<std::uint32_t, 2> daemon_ids{0x181, 0x182};
  SocketCanBus daemon(test_interface(), daemon_ids);
  SocketCanBus node(test_interface(), node_ids);
  CHECK(daemon.state() == BusState::kActive);
  CHECK(daemon.error_frames() == 0);

  const std::int64_t before_ns = monotonic_ns();
  REQUIRE(daemon.send(frame_of(0x080, {17})));
  ReceivedFrame received;
  REQUIRE(node.receive(received, monotonic_ns() + 100'000'000));
  const std::int64_t after_ns = monotonic_ns();
  CHECK(received.frame.id == 0x080);
  CHECK(received.frame.dlc == 1);
  CHECK(received.frame.data[0] == 17);
  // Allow 1 ms for the REALTIME − MONOTONIC offset sampled after the read.
  CHECK(received.timestamp_ns >= before_ns - 1'000'000);
  CHECK(received.timestamp_ns <= after_ns + 1'000'000);

  REQUIRE(node.send(frame_of(0x182, {1, 2, 3, 4, 5, 6, 7, 8})));
  REQUIRE(daemon.receive(received, monotonic_ns() + 100'000'000));
  CHECK(received.frame.id == 0x182);
  CHECK(received.frame.dlc == 8);
  CHECK(received.frame.data == std::array<std::uint8_t, 8>{1, 2, 3, 4, 5, 6, 7, 8});
}

TEST_CASE("on vcan frames outside the receive list are filtered and receive returns false at the deadline",
          "[can][socketcan][vcan]") {
  if (!vcan_available()) return;
  const std::array<std::uint32_t, 1> daemon_ids{0x181};
  const std::array<std::uint32_t, 0> none{};
  SocketCanBus daemon(test_interface(), daemon_ids);
  SocketCanBus node(test_interface(), none);
  REQUIRE(node.send(frame_of(0x183, {1})));  // another node's TPDO1
  REQUIRE(node.send(frame_of(0x201, {1, 2, 3, 4, 5, 6})));

  ReceivedFrame received;
  received.timestamp_ns = 42;
  const std::int64_t start_ns = monotonic_ns();
  CHECK_FALSE(daemon.receive(received, start_ns + 20'000'000));
  const std::int64_t waited_ns = monotonic_ns() - start_ns;
  CHECK(waited_ns >= 20'000'000);
  CHECK(waited_ns < 200'000'000);
  CHECK(received.timestamp_ns == 42);  // untouched
  // A deadline in the past returns at once.
  CHECK_FALSE(daemon.receive(received, 0));
}

TEST_CASE("on vcan sending and receiving 1e4 frames does not allocate", "[can][socketcan][vcan][allocation]") {
  if (!vcan_available()) return;
  const std::array<std::uint32_t, 1> ids{0x181};
  const std::array<std::uint32_t, 0> none{};
  SocketCanBus daemon(test_interface(), ids);
  SocketCanBus node(test_interface(), none);
  const auto frame = frame_of(0x181, {1, 2, 3, 4, 5, 6, 7});
  ReceivedFrame received;
  int delivered = 0;
  clm::test::AllocationScope scope;
  for (int i = 0; i < 10000; ++i) {
    if (node.send(frame) && daemon.receive(received, monotonic_ns() + 100'000'000)) ++delivered;
  }
  const std::size_t allocations = scope.allocations();
  CHECK(allocations == 0);
  CHECK(delivered == 10000);
  CHECK(daemon.dropped_frames() == 0);
}
