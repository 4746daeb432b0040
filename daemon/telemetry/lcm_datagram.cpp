#include "daemon/telemetry/lcm_datagram.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace clm::telemetry {
namespace {

std::uint32_t read_u32(const std::uint8_t* p) noexcept {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

constexpr std::size_t kShortHeaderBytes = 8;
constexpr std::size_t kFragmentHeaderBytes = 20;
constexpr int kDefaultReceiveBufferBytes = 4 * 1024 * 1024;  // as with_receive_buffer

/// A whole number in [min, max], or throws naming `what`.
long number_in(const std::string& url, const std::string& what, const std::string& text, long min, long max) {
  if (text.empty() || text.size() > 10 || text.find_first_not_of("0123456789") != std::string::npos ||
      std::stol(text) < min || std::stol(text) > max) {
    throw std::invalid_argument("LCM URL '" + url + "': " + what + " '" + text + "' is not a whole number in [" +
                                std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  return std::stol(text);
}

}  // namespace

LcmDatagram check_lcm_datagram(std::span<const std::uint8_t> datagram) noexcept {
  LcmDatagram out;
  if (datagram.size() < kShortHeaderBytes) return out;
  const std::uint32_t magic = read_u32(datagram.data());
  if (magic == kLcmFragmentMagic) {
    if (datagram.size() < kFragmentHeaderBytes) return out;
    out.kind = DatagramKind::kFragment;
    out.claimed_bytes = read_u32(datagram.data() + 8);
    return out;
  }
  if (magic != kLcmShortMagic) return out;
  const auto* name = reinterpret_cast<const char*>(datagram.data() + kShortHeaderBytes);
  const std::size_t room = datagram.size() - kShortHeaderBytes;
  const void* nul = std::memchr(name, 0, std::min(room, kLcmMaxChannelBytes + 1));
  if (nul == nullptr) return out;
  const auto length = static_cast<std::size_t>(static_cast<const char*>(nul) - name);
  out.kind = DatagramKind::kShort;
  out.channel = std::string_view(name, length);
  out.payload = datagram.subspan(kShortHeaderBytes + length + 1);
  return out;
}

UdpmAddress parse_udpm_url(const std::string& url) {
  constexpr std::string_view scheme = "udpm://";
  if (url.rfind(scheme, 0) != 0) {
    throw std::invalid_argument("LCM URL '" + url + "': clm-servod receives commands over udpm:// only");
  }
  UdpmAddress address{"239.255.76.67", 7667, kDefaultReceiveBufferBytes};
  const std::size_t query = url.find('?');
  const std::string target = url.substr(scheme.size(), query == std::string::npos ? std::string::npos
                                                                                   : query - scheme.size());
  if (!target.empty()) {
    const std::size_t colon = target.find(':');
    address.group = target.substr(0, colon);
    if (colon != std::string::npos) {
      address.port = static_cast<std::uint16_t>(number_in(url, "port", target.substr(colon + 1), 1, 65535));
    }
  }
  in_addr group{};
  if (inet_pton(AF_INET, address.group.c_str(), &group) != 1 || !IN_MULTICAST(ntohl(group.s_addr))) {
    throw std::invalid_argument("LCM URL '" + url + "': '" + address.group + "' is not an IPv4 multicast group");
  }
  if (query != std::string::npos) {
    std::size_t pos = query + 1;
    while (pos < url.size()) {
      const std::size_t end = std::min(url.find('&', pos), url.size());
      const std::string option = url.substr(pos, end - pos);
      if (option.rfind("recv_buf_size=", 0) == 0) {
        address.receive_buffer_bytes =
            static_cast<int>(number_in(url, "recv_buf_size", option.substr(14), 1024, 1L << 30));
      }
      pos = end + 1;
    }
  }
  return address;
}

UdpmReceiver::UdpmReceiver(const UdpmAddress& address) {
  const std::string where = "udpm://" + address.group + ":" + std::to_string(address.port);
  const auto fail = [&](const std::string& call) {
    const std::string reason = std::strerror(errno);
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    throw std::runtime_error("telemetry: cannot receive on " + where + ": " + call + ": " + reason +
                             " (udpm needs a multicast route, see docs/telemetry.md)");
  };
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) fail("socket");
  const int one = 1;
  // As liblcm: every process on the host that listens on the port gets each datagram.
  if (::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0) fail("SO_REUSEADDR");
  // Best effort, as liblcm: the kernel caps it at net.core.rmem_max.
  const int bytes = address.receive_buffer_bytes;
  (void)::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes);
  sockaddr_in bound{};
  bound.sin_family = AF_INET;
  bound.sin_addr.s_addr = htonl(INADDR_ANY);
  bound.sin_port = htons(address.port);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&bound), sizeof bound) != 0) fail("bind");
  ip_mreq membership{};
  inet_pton(AF_INET, address.group.c_str(), &membership.imr_multiaddr);
  membership.imr_interface.s_addr = htonl(INADDR_ANY);
  if (::setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &membership, sizeof membership) != 0) fail("IP_ADD_MEMBERSHIP");
}

UdpmReceiver::~UdpmReceiver() {
  if (fd_ >= 0) ::close(fd_);
}

long UdpmReceiver::receive(std::span<std::uint8_t> buffer, int timeout_ms) noexcept {
  pollfd ready{fd_, POLLIN, 0};
  const int polled = ::poll(&ready, 1, timeout_ms);
  if (polled == 0 || (polled < 0 && errno == EINTR)) return 0;
  if (polled < 0) return -1;
  // MSG_TRUNC: the datagram's real length even when the buffer is shorter.
  const ssize_t length = ::recv(fd_, buffer.data(), buffer.size(), MSG_TRUNC | MSG_DONTWAIT);
  if (length < 0) return errno == EAGAIN || errno == EINTR ? 0 : -1;
  return static_cast<long>(length);
}

}  // namespace clm::telemetry
