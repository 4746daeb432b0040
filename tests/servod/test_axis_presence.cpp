// The session id and the start-up check for another daemon of the same axis
// (daemon/servod/axis_presence.hpp).
#include <catch2/catch.hpp>

#include <lcm/lcm-cpp.hpp>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <set>
#include <thread>

#include "clm_lcm/servo_status_t.hpp"
#include "daemon/servod/axis_presence.hpp"
#include "support/signed_lcm.hpp"
#include "daemon/telemetry/telemetry.hpp"

using namespace clm::servod;

TEST_CASE("Session ids are random and never 0", "[servod][authority]") {
  std::set<std::int64_t> seen;
  for (int k = 0; k < 1000; ++k) {
    const std::int64_t id = draw_session_id();
    CHECK(id != 0);
    seen.insert(id);
  }
  CHECK(seen.size() == 1000);
}

TEST_CASE("Start-up listens 2.5 status periods, at least 0.3 s", "[servod][authority]") {
  CHECK(presence_window_s(10.0) == Approx(0.3));
  CHECK(presence_window_s(1.0) == Approx(2.5));
  CHECK(presence_window_s(100.0) == Approx(0.3));
  CHECK(presence_window_s(0.0) == Approx(0.3));
}

TEST_CASE("Another session's status of the same axis is found, the own session, other axes and statuses without "
          "the key's mac are not",
          "[servod][authority][lcm]") {
  // A port of its own (10160..10199, next to tests/servod/servod_authority_test.sh's).
  const std::string url = "udpm://239.255.76.67:" + std::to_string(10160 + ::getpid() % 40) + "?ttl=0";
  lcm::LCM other(url);
  if (!other.good()) FAIL("cannot open " + url + " (udpm needs a multicast route, docs/telemetry.md)");
  const clm::HmacSha256 key = clm::test::key_of("the operators' key of this test, 32+ bytes");
  const clm::HmacSha256 other_key = clm::test::key_of("a key the daemon does not hold, 32+ bytes");
  std::atomic<std::int64_t> session{0};
  std::atomic<bool> stop{false};
  std::thread publisher([&] {
    while (!stop.load()) {
      clm_lcm::servo_status_t status{};
      status.axis = "axis0";
      status.session = session.load();
      status.fault_cycle = -1;
      clm::test::publish_signed(other, clm::telemetry::kStatusChannel, status, &key);
      clm_lcm::servo_status_t elsewhere = status;
      elsewhere.axis = "axis1";
      elsewhere.session = 999;
      clm::test::publish_signed(other, clm::telemetry::kStatusChannel, elsewhere, &key);
      clm_lcm::servo_status_t forged = status;  // made up without the key
      forged.session = 77;
      clm::test::publish_signed(other, clm::telemetry::kStatusChannel, forged, &other_key);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  session = 41;
  CHECK(other_session_of_axis(url, "axis0", 42, 0.5, key) == 41);
  CHECK(other_session_of_axis(url, "axis0", 41, 0.3, key) == 0);
  CHECK_THROWS_WITH(require_axis_free(url, "axis0", 42, 10.0, key),
                    Catch::Contains("axis 'axis0' is already driven on " + url + " by session 41"));
  CHECK(other_session_of_axis(url, "axis2", 42, 0.3, key) == 0);
  // Holding only the forged statuses' key: session 41's are not signed with it, and 77's are, so it is found.
  CHECK(other_session_of_axis(url, "axis0", 42, 0.5, other_key) == 77);
  stop = true;
  publisher.join();
}
