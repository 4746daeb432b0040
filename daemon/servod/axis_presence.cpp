#include "daemon/servod/axis_presence.hpp"

#include <sys/random.h>

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <span>
#include <stdexcept>

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

namespace {

struct StatusListener {
  std::string axis;
  std::int64_t own_session = 0;
  std::int64_t other_session = 0;
  void on_status(const lcm::ReceiveBuffer* buffer, const std::string& /*channel*/) {
    clm_lcm::servo_status_t status;
    const std::span<const std::uint8_t> datagram(static_cast<const std::uint8_t*>(buffer->data), buffer->data_size);
    try {
      if (!telemetry::decode_checked(datagram, status).empty()) return;
    } catch (const std::exception&) {
      return;
    }
    if (status.axis == axis && status.session != own_session && other_session == 0) other_session = status.session;
  }
};

}  // namespace

std::int64_t other_session_of_axis(const std::string& lcm_url, const std::string& axis, std::int64_t own_session,
                                   double listen_s) {
  lcm::LCM lcm(lcm_url);
  if (!lcm.good()) {
    throw std::runtime_error("cannot open LCM at '" + lcm_url + "' (udpm needs a multicast route, see docs/telemetry.md)");
  }
  StatusListener listener{axis, own_session, 0};
  lcm.subscribe(telemetry::kStatusChannel, &StatusListener::on_status, &listener);
  using Clock = std::chrono::steady_clock;
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(listen_s));
  while (listener.other_session == 0) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
    if (left <= 0) break;
    lcm.handleTimeout(static_cast<int>(std::min<long long>(left, 100)));
  }
  return listener.other_session;
}

void require_axis_free(const std::string& lcm_url, const std::string& axis, std::int64_t own_session,
                       double status_rate_hz) {
  const std::int64_t other = other_session_of_axis(lcm_url, axis, own_session, presence_window_s(status_rate_hz));
  if (other != 0) {
    throw std::runtime_error("axis '" + axis + "' is already driven on " + lcm_url + " by session " +
                             std::to_string(other) + " (another clm-servod): not starting a second one");
  }
}

}  // namespace clm::servod
