#include "drivers/socket_can_bus.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace clm::drivers {
namespace {

std::string errno_text(int error) { return std::generic_category().message(error); }

[[noreturn]] void fail(const std::string& interface_name, const std::string& what, int error) {
  throw std::runtime_error("socketcan: " + what + " on interface '" + interface_name + "': " + errno_text(error));
}

/// Closes a descriptor unless released, so a throwing constructor leaks nothing.
class DescriptorGuard {
 public:
  explicit DescriptorGuard(int fd) : fd_(fd) {}
  ~DescriptorGuard() {
    if (fd_ >= 0) ::close(fd_);
  }
  DescriptorGuard(const DescriptorGuard&) = delete;
  DescriptorGuard& operator=(const DescriptorGuard&) = delete;
  int get() const { return fd_; }
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_;
};

std::int64_t clock_ns(clockid_t clock) noexcept {
  timespec now{};
  ::clock_gettime(clock, &now);
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

void set_option(int fd, int level, int option, const void* value, socklen_t length, const std::string& interface_name,
                const char* option_name) {
  if (::setsockopt(fd, level, option, value, length) != 0) {
    fail(interface_name, std::string("setsockopt(") + option_name + ") failed", errno);
  }
}

}  // namespace

BusState bus_state_after_error(BusState current, std::uint32_t error_class, std::uint8_t controller_status) noexcept {
  if ((error_class & CAN_ERR_BUSOFF) != 0) return BusState::kBusOff;
  BusState next = current;
  if ((error_class & CAN_ERR_RESTARTED) != 0) next = BusState::kActive;
  if ((error_class & CAN_ERR_CRTL) != 0) {
    if ((controller_status & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0) {
      if (next != BusState::kBusOff) next = BusState::kErrorPassive;
    } else if ((controller_status & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0) {
      if (next != BusState::kBusOff) next = BusState::kErrorWarning;
    } else if ((controller_status & CAN_ERR_CRTL_ACTIVE) != 0) {
      next = BusState::kActive;
    }
  }
  return next;
}

SocketCanBus::SocketCanBus(const std::string& interface_name, std::span<const std::uint32_t> receive_ids)
    : interface_name_(interface_name) {
  for (const std::uint32_t id : receive_ids) {
    if (id > CAN_SFF_MASK) {
      throw std::invalid_argument("socketcan: receive identifier " + std::to_string(id) + " for interface '" +
                                  interface_name + "' is not a standard 11-bit identifier (0..0x7FF)");
    }
  }
  if (receive_ids.size() > CAN_RAW_FILTER_MAX) {
    throw std::invalid_argument("socketcan: " + std::to_string(receive_ids.size()) +
                                " receive identifiers for interface '" + interface_name + "', at most " +
                                std::to_string(CAN_RAW_FILTER_MAX));
  }

  if (interface_name.empty() || interface_name.size() >= IFNAMSIZ) {
    throw std::runtime_error("socketcan: interface name '" + interface_name + "' must have 1.." +
                             std::to_string(IFNAMSIZ - 1) + " characters");
  }

  DescriptorGuard socket_fd(::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW));
  if (socket_fd.get() < 0) {
    const int error = errno;
    std::string message =
        "socketcan: cannot open CAN socket for interface '" + interface_name + "': " + errno_text(error);
    if (error == EAFNOSUPPORT) message += " (this kernel has no SocketCAN)";
    throw std::runtime_error(message);
  }

  ifreq request{};
  std::memcpy(request.ifr_name, interface_name.c_str(), interface_name.size() + 1);
  if (::ioctl(socket_fd.get(), SIOCGIFINDEX, &request) != 0) {
    const int error = errno;
    if (error == ENODEV) {
      throw std::runtime_error("socketcan: no interface '" + interface_name + "': " + errno_text(error) +
                               " (see `ip link show type can`)");
    }
    fail(interface_name, "SIOCGIFINDEX failed", error);
  }
  const int interface_index = request.ifr_ifindex;
  if (::ioctl(socket_fd.get(), SIOCGIFFLAGS, &request) != 0) fail(interface_name, "SIOCGIFFLAGS failed", errno);
  if ((request.ifr_flags & IFF_UP) == 0) {
    throw std::runtime_error("socketcan: interface '" + interface_name +
                             "' is down (e.g. `ip link set " + interface_name + " up type can bitrate 1000000`)");
  }

  // Exactly the wanted identifiers: standard frame format, data frames only.
  std::vector<can_filter> filters;
  filters.reserve(receive_ids.size());
  for (const std::uint32_t id : receive_ids) {
    filters.push_back(can_filter{id, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
  }
  set_option(socket_fd.get(), SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
             static_cast<socklen_t>(filters.size() * sizeof(can_filter)), interface_name, "CAN_RAW_FILTER");
  const can_err_mask_t error_mask = CAN_ERR_MASK;
  set_option(socket_fd.get(), SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &error_mask, sizeof error_mask, interface_name,
             "CAN_RAW_ERR_FILTER");
  const int enable = 1;
  set_option(socket_fd.get(), SOL_SOCKET, SO_TIMESTAMPNS, &enable, sizeof enable, interface_name, "SO_TIMESTAMPNS");
  set_option(socket_fd.get(), SOL_SOCKET, SO_RXQ_OVFL, &enable, sizeof enable, interface_name, "SO_RXQ_OVFL");

  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = interface_index;
  if (::bind(socket_fd.get(), reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const int error = errno;
    throw std::runtime_error("socketcan: cannot bind to interface '" + interface_name + "': " + errno_text(error) +
                             (error == ENODEV ? " (not a CAN interface)" : ""));
  }
  fd_ = socket_fd.release();
}

SocketCanBus::~SocketCanBus() {
  if (fd_ >= 0) ::close(fd_);
}

bool SocketCanBus::send(const clm::can::Frame& frame) noexcept {
  if (frame.id > CAN_SFF_MASK || frame.dlc > CAN_MAX_DLEN) return false;
  can_frame raw{};
  raw.can_id = frame.id;
  raw.len = frame.dlc;
  std::memcpy(raw.data, frame.data.data(), frame.dlc);
  // Non-blocking: a full transmit queue gives ENOBUFS or EAGAIN, reported as false.
  const ssize_t written = ::write(fd_, &raw, CAN_MTU);
  return written == static_cast<ssize_t>(CAN_MTU);
}

void SocketCanBus::handle_error_frame(std::uint32_t can_id, const std::uint8_t* data) noexcept {
  error_frames_.fetch_add(1, std::memory_order_relaxed);
  state_.store(bus_state_after_error(state_.load(std::memory_order_relaxed), can_id & CAN_ERR_MASK, data[1]),
               std::memory_order_relaxed);
}

bool SocketCanBus::receive(ReceivedFrame& out, std::int64_t deadline_ns) noexcept {
  for (;;) {
    can_frame raw{};
    iovec buffer{&raw, sizeof raw};
    alignas(cmsghdr) unsigned char control[CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t))];
    msghdr message{};
    message.msg_iov = &buffer;
    message.msg_iovlen = 1;
    message.msg_control = control;
    message.msg_controllen = sizeof control;

    const ssize_t length = ::recvmsg(fd_, &message, MSG_DONTWAIT);
    if (length < 0) {
      const int error = errno;
      if (error == EINTR) continue;
      if (error != EAGAIN && error != EWOULDBLOCK) socket_errors_.fetch_add(1, std::memory_order_relaxed);
      // Nothing to read: wait for the socket until the deadline.
      const std::int64_t remaining_ns = deadline_ns - clock_ns(CLOCK_MONOTONIC);
      if (remaining_ns <= 0) return false;
      pollfd waiting{fd_, POLLIN, 0};
      const timespec timeout{static_cast<time_t>(remaining_ns / 1'000'000'000),
                             static_cast<long>(remaining_ns % 1'000'000'000)};
      if (::ppoll(&waiting, 1, &timeout, nullptr) < 0 && errno != EINTR) {
        socket_errors_.fetch_add(1, std::memory_order_relaxed);
        return false;
      }
      continue;
    }
    if (length != static_cast<ssize_t>(CAN_MTU)) continue;  // not a classic CAN frame

    std::int64_t timestamp_ns = -1;
    for (cmsghdr* header = CMSG_FIRSTHDR(&message); header != nullptr; header = CMSG_NXTHDR(&message, header)) {
      if (header->cmsg_level != SOL_SOCKET) continue;
      if (header->cmsg_type == SCM_TIMESTAMPNS) {
        timespec stamp{};
        std::memcpy(&stamp, CMSG_DATA(header), sizeof stamp);
        const std::int64_t realtime_ns = static_cast<std::int64_t>(stamp.tv_sec) * 1'000'000'000 + stamp.tv_nsec;
        timestamp_ns = realtime_ns - (clock_ns(CLOCK_REALTIME) - clock_ns(CLOCK_MONOTONIC));
      } else if (header->cmsg_type == SO_RXQ_OVFL) {
        std::uint32_t dropped = 0;  // the kernel's running count for this socket
        std::memcpy(&dropped, CMSG_DATA(header), sizeof dropped);
        dropped_frames_.store(dropped, std::memory_order_relaxed);
      }
    }

    if ((raw.can_id & CAN_ERR_FLAG) != 0) {
      handle_error_frame(raw.can_id, raw.data);
      if (clock_ns(CLOCK_MONOTONIC) >= deadline_ns) return false;
      continue;
    }
    if ((raw.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG)) != 0 || raw.len > CAN_MAX_DLEN) continue;  // filtered anyway

    out.frame.id = raw.can_id & CAN_SFF_MASK;
    out.frame.dlc = raw.len;
    out.frame.data.fill(0);
    std::memcpy(out.frame.data.data(), raw.data, raw.len);
    out.timestamp_ns = timestamp_ns >= 0 ? timestamp_ns : clock_ns(CLOCK_MONOTONIC);
    return true;
  }
}

}  // namespace clm::drivers
