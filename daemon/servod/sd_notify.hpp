#pragma once
// systemd's notification protocol without libsystemd (sd_notify(3)): one
// datagram of newline-separated VAR=value lines to the AF_UNIX socket named
// by $NOTIFY_SOCKET (a path, or an abstract name when it starts with '@').
// Outside systemd $NOTIFY_SOCKET is unset and every call does nothing.
//
// ServiceMonitor is clm-servod's watchdog: a non-real-time thread that sends
// WATCHDOG=1 every WatchdogSec/2 only while the loop's cycle counter
// advances, so a stalled loop stops the pings and systemd restarts the
// service; it also keeps STATUS= up to date.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>

namespace clm::servod {

class SystemdNotifier {
 public:
  /// Notifies the socket at `socket_path` ("@name": abstract namespace);
  /// empty: disabled. Throws std::invalid_argument when the path does not
  /// fit a sockaddr_un (107 bytes), std::runtime_error when no socket can be
  /// created.
  explicit SystemdNotifier(std::string socket_path);
  /// From $NOTIFY_SOCKET; disabled when it is unset or empty.
  static SystemdNotifier from_environment();
  ~SystemdNotifier();
  SystemdNotifier(SystemdNotifier&& other) noexcept;
  SystemdNotifier& operator=(SystemdNotifier&&) = delete;
  SystemdNotifier(const SystemdNotifier&) = delete;
  SystemdNotifier& operator=(const SystemdNotifier&) = delete;

  bool enabled() const noexcept { return fd_ >= 0; }
  const std::string& socket_path() const noexcept { return path_; }

  /// Sends `state` ("READY=1", "STATUS=…", several lines at once) as one
  /// datagram. 0, or the errno of sendto (e.g. ECONNREFUSED when nobody
  /// listens). Disabled: 0. Safe from several threads.
  int notify(std::string_view state) const noexcept;

 private:
  std::string path_;
  int fd_ = -1;
};

/// The watchdog period systemd expects pings within [s]: $WATCHDOG_USEC
/// when set and meant for this process ($WATCHDOG_PID unset or equal to
/// getpid()); 0 when there is no watchdog. Throws std::runtime_error when
/// $WATCHDOG_USEC is not a positive integer.
double watchdog_period_from_environment();

class ServiceMonitor {
 public:
  /// `cycles`: the loop's cycle counter (ServoDaemon::cycles_done), read
  /// from the monitor thread. `status`: one line for STATUS= (state and
  /// fault), sent when the thread starts and whenever it changes; may be empty.
  using CycleCounter = std::function<std::int64_t()>;
  using StatusText = std::function<std::string()>;

  /// `watchdog_period_s` > 0: ping WATCHDOG=1 every half period while the
  /// counter advances. 0: no pings; STATUS= is then checked every
  /// `status_period_s`. Does not start the thread.
  ServiceMonitor(const SystemdNotifier& notifier, double watchdog_period_s, CycleCounter cycles,
                 StatusText status = {}, double status_period_s = 0.5);
  /// stop().
  ~ServiceMonitor();
  ServiceMonitor(const ServiceMonitor&) = delete;
  ServiceMonitor& operator=(const ServiceMonitor&) = delete;

  /// Starts the thread (std::logic_error when it runs already).
  void start();
  /// Stops and joins the thread; idempotent.
  void stop();

  /// The monitor's check period [s]: half the watchdog period, else the status period.
  double check_period_s() const noexcept { return check_period_s_; }
  /// WATCHDOG=1 datagrams sent.
  std::int64_t pings() const noexcept { return pings_.load(std::memory_order_relaxed); }
  /// Checks at which the counter had not moved since the previous one (no ping sent).
  std::int64_t stalls() const noexcept { return stalls_.load(std::memory_order_relaxed); }

 private:
  void run();

  const SystemdNotifier& notifier_;
  bool watchdog_;
  double check_period_s_;
  CycleCounter cycles_;
  StatusText status_;
  std::atomic<std::int64_t> pings_{0};
  std::atomic<std::int64_t> stalls_{0};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_requested_ = false;
  std::thread thread_;
};

}  // namespace clm::servod
