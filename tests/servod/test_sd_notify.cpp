// The systemd notification protocol and the loop watchdog, against a unix
// datagram socket bound by the test in place of systemd.
#include <catch2/catch.hpp>

#include <poll.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "daemon/servod/sd_notify.hpp"
#include "support/temporary_directory.hpp"

using namespace clm::servod;

namespace {

/// Plays systemd: a bound AF_UNIX datagram socket that collects what arrives.
class FakeSystemd {
 public:
  /// `abstract`: bind in the abstract namespace and give "@name" as the path.
  explicit FakeSystemd(bool abstract) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    REQUIRE(fd_ >= 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    const std::string name = "clm_servod_notify_" + std::to_string(::getpid()) + (abstract ? "_abstract" : "_path");
    socklen_t length = 0;
    if (abstract) {
      std::memcpy(address.sun_path + 1, name.data(), name.size());
      length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + name.size());
      path_ = "@" + name;
    } else {
      directory_.emplace("clm_servod_notify");
      path_ = directory_->file(name);
      std::memcpy(address.sun_path, path_.data(), path_.size());
      length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + path_.size() + 1);
    }
    REQUIRE(::bind(fd_, reinterpret_cast<const sockaddr*>(&address), length) == 0);
  }
  ~FakeSystemd() { ::close(fd_); }
  const std::string& path() const { return path_; }

  /// Every datagram that arrives within `timeout_ms` after the last one.
  std::vector<std::string> receive(int timeout_ms = 50) {
    std::vector<std::string> messages;
    pollfd p{fd_, POLLIN, 0};
    while (::poll(&p, 1, timeout_ms) == 1) {
      char buffer[4096];
      const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
      if (n < 0) break;
      messages.emplace_back(buffer, static_cast<std::size_t>(n));
    }
    return messages;
  }

 private:
  int fd_ = -1;
  std::optional<clm::test::TemporaryDirectory> directory_;  ///< holds the socket file (not abstract)
  std::string path_;
};

/// Sets an environment variable for the scope of a test.
class ScopedEnvironment {
 public:
  ScopedEnvironment(const char* name, const std::string& value) : name_(name) { ::setenv(name, value.c_str(), 1); }
  ~ScopedEnvironment() { ::unsetenv(name_); }

 private:
  const char* name_;
};

int count(const std::vector<std::string>& messages, const std::string& text) {
  int n = 0;
  for (const auto& m : messages) n += m == text ? 1 : 0;
  return n;
}

}  // namespace

TEST_CASE("Without NOTIFY_SOCKET the notifier is disabled and sending does nothing", "[servod][sd_notify]") {
  ::unsetenv("NOTIFY_SOCKET");
  const auto notifier = SystemdNotifier::from_environment();
  CHECK_FALSE(notifier.enabled());
  CHECK(notifier.notify("READY=1") == 0);
}

TEST_CASE("READY, STATUS and STOPPING arrive as datagrams at the NOTIFY_SOCKET path", "[servod][sd_notify]") {
  FakeSystemd systemd(false);
  const ScopedEnvironment socket("NOTIFY_SOCKET", systemd.path());
  const auto notifier = SystemdNotifier::from_environment();
  REQUIRE(notifier.enabled());
  CHECK(notifier.notify("READY=1\nSTATUS=state disabled, fault 0 (none)") == 0);
  CHECK(notifier.notify("STOPPING=1") == 0);
  const auto messages = systemd.receive();
  REQUIRE(messages.size() == 2);
  CHECK(messages[0] == "READY=1\nSTATUS=state disabled, fault 0 (none)");
  CHECK(messages[1] == "STOPPING=1");
}

TEST_CASE("An NOTIFY_SOCKET starting with @ is a socket in the abstract namespace", "[servod][sd_notify]") {
  FakeSystemd systemd(true);
  const ScopedEnvironment socket("NOTIFY_SOCKET", systemd.path());
  const auto notifier = SystemdNotifier::from_environment();
  CHECK(notifier.notify("READY=1") == 0);
  const auto messages = systemd.receive();
  REQUIRE(messages.size() == 1);
  CHECK(messages[0] == "READY=1");
}

TEST_CASE("Notifying a socket nobody listens on returns the errno and does not throw", "[servod][sd_notify]") {
  const clm::test::TemporaryDirectory directory("clm_servod_notify");
  const SystemdNotifier notifier(directory.file("no_such_socket"));
  CHECK(notifier.notify("READY=1") != 0);
}

TEST_CASE("A NOTIFY_SOCKET that is relative or too long is refused with a message", "[servod][sd_notify]") {
  CHECK_THROWS_WITH(SystemdNotifier("run/notify"), Catch::Contains("absolute path"));
  CHECK_THROWS_WITH(SystemdNotifier("/" + std::string(200, 'x')), Catch::Contains("longer than"));
}

TEST_CASE("WATCHDOG_USEC gives the watchdog period unless WATCHDOG_PID names another process", "[servod][sd_notify]") {
  ::unsetenv("WATCHDOG_USEC");
  ::unsetenv("WATCHDOG_PID");
  CHECK(watchdog_period_from_environment() == 0.0);
  {
    const ScopedEnvironment usec("WATCHDOG_USEC", "1000000");
    CHECK(watchdog_period_from_environment() == Approx(1.0));
    {
      const ScopedEnvironment pid("WATCHDOG_PID", std::to_string(::getpid()));
      CHECK(watchdog_period_from_environment() == Approx(1.0));
    }
    {
      const ScopedEnvironment pid("WATCHDOG_PID", std::to_string(::getpid() + 1));
      CHECK(watchdog_period_from_environment() == 0.0);
    }
  }
  const ScopedEnvironment bad("WATCHDOG_USEC", "1s");
  CHECK_THROWS_WITH(watchdog_period_from_environment(), Catch::Contains("WATCHDOG_USEC '1s'"));
}

TEST_CASE("The monitor pings WATCHDOG=1 while the cycle counter advances and stops when it stalls",
          "[servod][sd_notify]") {
  FakeSystemd systemd(false);
  const SystemdNotifier notifier(systemd.path());
  std::atomic<std::int64_t> cycles{0};
  std::atomic<bool> loop_running{true};
  // A stand-in for the loop thread: 1 kHz-ish counting until it "hangs".
  std::thread loop([&] {
    while (loop_running.load()) {
      cycles.fetch_add(1);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  // WatchdogSec = 0.1 s: a check every 50 ms.
  ServiceMonitor monitor(notifier, 0.1, [&] { return cycles.load(); }, [] { return std::string("state enabled"); });
  CHECK(monitor.check_period_s() == Approx(0.05));
  monitor.start();

  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  const auto running = systemd.receive(0);
  const int pings_running = count(running, "WATCHDOG=1");
  CHECK(pings_running >= 3);  // 8 checks in 0.4 s; allow for a loaded machine
  CHECK(count(running, "STATUS=state enabled") >= 1);

  loop_running.store(false);
  loop.join();  // the counter stops: a stalled loop
  // The first check after the stop may still see the last cycles and ping;
  // from the first check that sees no progress on, nothing may be pinged.
  const std::int64_t stalls_before = monitor.stalls();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (monitor.stalls() == stalls_before && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  REQUIRE(monitor.stalls() > stalls_before);
  const auto transition = systemd.receive(0);
  const std::int64_t pings_at_stall = monitor.pings();
  const std::int64_t first_stall = monitor.stalls();
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  const auto stalled = systemd.receive(0);
  monitor.stop();
  CHECK(count(stalled, "WATCHDOG=1") == 0);
  CHECK(monitor.pings() == pings_at_stall);
  CHECK(monitor.stalls() - first_stall >= 3);  // 8 checks in 0.4 s
  // STATUS= says so once, when the stall is first seen.
  bool stall_reported = false;
  for (const auto& m : transition) stall_reported = stall_reported || m.find("loop stalled at cycle") != std::string::npos;
  for (const auto& m : stalled) stall_reported = stall_reported || m.find("loop stalled at cycle") != std::string::npos;
  CHECK(stall_reported);
}

TEST_CASE("Without a watchdog the monitor sends STATUS on change and no WATCHDOG", "[servod][sd_notify]") {
  FakeSystemd systemd(false);
  const SystemdNotifier notifier(systemd.path());
  std::atomic<std::int64_t> cycles{0};
  std::atomic<int> fault{0};
  ServiceMonitor monitor(notifier, 0.0, [&] { return cycles.fetch_add(1) + 1; },
                         [&] { return "state enabled, fault " + std::to_string(fault.load()); }, 0.02);
  monitor.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  fault.store(203);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  monitor.stop();
  const auto messages = systemd.receive(0);
  CHECK(count(messages, "WATCHDOG=1") == 0);
  CHECK(count(messages, "STATUS=state enabled, fault 0") == 1);
  CHECK(count(messages, "STATUS=state enabled, fault 203") == 1);
}
