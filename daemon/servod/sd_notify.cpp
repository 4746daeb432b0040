#include "daemon/servod/sd_notify.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace clm::servod {
namespace {

/// The socket address of `path` and its length; '@' marks the abstract namespace.
socklen_t make_address(const std::string& path, sockaddr_un& address) {
  address = {};
  address.sun_family = AF_UNIX;
  // A path needs its NUL inside sun_path; an abstract name does not.
  const std::size_t capacity = path[0] == '@' ? sizeof(address.sun_path) : sizeof(address.sun_path) - 1;
  if (path.size() > capacity) {
    throw std::invalid_argument("NOTIFY_SOCKET '" + path + "': longer than the " + std::to_string(capacity) +
                                " bytes a unix socket address holds");
  }
  std::memcpy(address.sun_path, path.data(), path.size());
  if (path[0] == '@') address.sun_path[0] = '\0';
  // Abstract names are exactly as long as given: no trailing NUL counted.
  return static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + path.size() + (path[0] == '@' ? 0 : 1));
}

}  // namespace

SystemdNotifier::SystemdNotifier(std::string socket_path) : path_(std::move(socket_path)) {
  if (path_.empty()) return;
  if (path_[0] != '/' && path_[0] != '@') {
    throw std::invalid_argument("NOTIFY_SOCKET '" + path_ + "': expected an absolute path or an '@' abstract name");
  }
  sockaddr_un address{};
  make_address(path_, address);  // checks the length now, not at the first notify
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(std::string("NOTIFY_SOCKET: socket(AF_UNIX, SOCK_DGRAM): ") + std::strerror(errno));
}

SystemdNotifier SystemdNotifier::from_environment() {
  const char* path = std::getenv("NOTIFY_SOCKET");
  return SystemdNotifier(path != nullptr ? path : "");
}

SystemdNotifier::~SystemdNotifier() {
  if (fd_ >= 0) ::close(fd_);
}

SystemdNotifier::SystemdNotifier(SystemdNotifier&& other) noexcept : path_(std::move(other.path_)), fd_(other.fd_) {
  other.fd_ = -1;
}

int SystemdNotifier::notify(std::string_view state) const noexcept {
  if (fd_ < 0) return 0;
  sockaddr_un address{};
  socklen_t length = 0;
  try {
    length = make_address(path_, address);
  } catch (...) {
    return EINVAL;  // checked in the constructor; cannot happen
  }
  const ssize_t sent = ::sendto(fd_, state.data(), state.size(), MSG_NOSIGNAL,
                                reinterpret_cast<const sockaddr*>(&address), length);
  if (sent < 0) return errno;
  return static_cast<std::size_t>(sent) == state.size() ? 0 : EMSGSIZE;
}

double watchdog_period_from_environment() {
  const char* usec = std::getenv("WATCHDOG_USEC");
  if (usec == nullptr || *usec == '\0') return 0.0;
  if (const char* pid = std::getenv("WATCHDOG_PID"); pid != nullptr && *pid != '\0') {
    if (std::strtoll(pid, nullptr, 10) != static_cast<long long>(::getpid())) return 0.0;  // meant for another process
  }
  char* end = nullptr;
  errno = 0;
  const unsigned long long value = std::strtoull(usec, &end, 10);
  if (errno != 0 || *end != '\0' || value == 0 || usec[0] == '-') {
    throw std::runtime_error(std::string("WATCHDOG_USEC '") + usec + "': expected a positive number of microseconds");
  }
  return static_cast<double>(value) * 1e-6;
}

ServiceMonitor::ServiceMonitor(const SystemdNotifier& notifier, double watchdog_period_s, CycleCounter cycles,
                               StatusText status, double status_period_s)
    : notifier_(notifier),
      watchdog_(watchdog_period_s > 0.0),
      check_period_s_(watchdog_period_s > 0.0 ? 0.5 * watchdog_period_s : status_period_s),
      cycles_(std::move(cycles)),
      status_(std::move(status)) {
  if (!(check_period_s_ > 0.0)) throw std::invalid_argument("ServiceMonitor: the status period must be positive");
}

ServiceMonitor::~ServiceMonitor() { stop(); }

void ServiceMonitor::start() {
  if (thread_.joinable()) throw std::logic_error("ServiceMonitor::start: already running");
  {
    const std::lock_guard lock(mutex_);
    stop_requested_ = false;
  }
  thread_ = std::thread([this] { run(); });
}

void ServiceMonitor::stop() {
  {
    const std::lock_guard lock(mutex_);
    stop_requested_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void ServiceMonitor::run() {
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(check_period_s_));
  std::int64_t last_cycles = cycles_();
  std::string last_status = status_ ? status_() : std::string();
  if (!last_status.empty()) notifier_.notify("STATUS=" + last_status);
  auto next = std::chrono::steady_clock::now() + period;
  std::unique_lock lock(mutex_);
  while (true) {
    if (wake_.wait_until(lock, next, [this] { return stop_requested_; })) return;
    next += period;
    lock.unlock();
    const std::int64_t now_cycles = cycles_();
    const bool advanced = now_cycles != last_cycles;
    last_cycles = now_cycles;
    if (!advanced) stalls_.fetch_add(1, std::memory_order_relaxed);
    if (watchdog_ && advanced && notifier_.notify("WATCHDOG=1") == 0) pings_.fetch_add(1, std::memory_order_relaxed);
    std::string status = status_ ? status_() : std::string();
    if (!advanced) status += (status.empty() ? "" : "; ") + std::string("loop stalled at cycle ") + std::to_string(now_cycles);
    if (!status.empty() && status != last_status) {
      notifier_.notify("STATUS=" + status);
      last_status = std::move(status);
    }
    lock.lock();
  }
}

}  // namespace clm::servod
