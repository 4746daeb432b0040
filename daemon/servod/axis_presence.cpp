#include "daemon/servod/axis_presence.hpp"

#include <sys/random.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <span>
#include <stdexcept>
#include <vector>

#include "daemon/telemetry/lcm_datagram.hpp"
#include "daemon/telemetry/message_mac.hpp"
#include "daemon/telemetry/messages.hpp"
#include "daemon/telemetry/wire_check.hpp"

namespace clm::servod {

std::int64_t draw_session_id() {
  for (int attempt = 0; attempt < 8; ++attempt) {
    std::int64_t id = 0;
    const ssize_t got = ::getrandom(&id, sizeof(id), 0);
    if (got != static_cast<ssize_t>(sizeof(id))) {
      if (got < 0 && errno == EINTR) continue;
      throw std::runtime_error(std::string("getrandom for the session id failed: ") +
                               (got < 0 ? std::strerror(errno) : "short read"));
    }
    if (id != 0) return id;
  }
  throw std::runtime_error("getrandom gave a session id of 0 eight times");
}

double presence_window_s(double status_rate_hz) {
  return std::max(0.3, status_rate_hz > 0.0 ? 2.5 / status_rate_hz : 0.3);
}

std::int64_t other_session_of_axis(const std::string& lcm_url, const std::string& axis, std::int64_t own_session,
                                   double listen_s, const HmacSha256& key) {
  // The daemon's own reader, not liblcm's (daemon/telemetry/lcm_datagram.hpp):
  // a fragment claiming a huge message sizes nothing here either.
  telemetry::UdpmReceiver receiver(telemetry::parse_udpm_url(lcm_url));
  std::vector<std::uint8_t> buffer(telemetry::kLcmShortMessageMaxBytes + 64);
  using Clock = std::chrono::steady_clock;
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(listen_s));
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
    if (left <= 0) return 0;
    const long length = receiver.receive(buffer, static_cast<int>(std::min<long long>(left, 100)));
    if (length <= 0 || static_cast<std::size_t>(length) > buffer.size()) continue;
    const telemetry::LcmDatagram datagram =
        telemetry::check_lcm_datagram(std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(length)));
    if (datagram.kind != telemetry::DatagramKind::kShort || datagram.channel != telemetry::kStatusChannel) continue;
    clm_lcm::servo_status_t status;
    try {
      if (!telemetry::decode_checked(datagram.payload, status).empty()) continue;
      if (!telemetry::verify_encoded(key, telemetry::kStatusChannel, datagram.payload)) continue;
    } catch (const std::exception&) {
      continue;
    }
    if (status.axis == axis && status.session != own_session) return status.session;
  }
}

void require_axis_free(const std::string& lcm_url, const std::string& axis, std::int64_t own_session,
                       double status_rate_hz, const HmacSha256& key) {
  const std::int64_t other = other_session_of_axis(lcm_url, axis, own_session, presence_window_s(status_rate_hz), key);
  if (other != 0) {
    throw std::runtime_error("axis '" + axis + "' is already driven on " + lcm_url + " by session " +
                             std::to_string(other) + " (another clm-servod): not starting a second one");
  }
}

}  // namespace clm::servod
