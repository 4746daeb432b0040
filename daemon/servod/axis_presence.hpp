#pragma once
// A daemon run's identity and the check that no other daemon drives the same
// axis on the same LCM URL (docs/servod.md "Command authority"). Start-up
// only: blocking, allocating, throwing.

#include <cstdint>
#include <string>

#include "config/sha256.hpp"

namespace clm::servod {

/// A random, non-zero session id from getrandom(2), new at every start.
/// Throws std::runtime_error when the kernel gives no random bytes.
std::int64_t draw_session_id();

/// How long start-up listens for another daemon: 2.5 status periods at
/// `status_rate_hz`, at least 0.3 s [s].
double presence_window_s(double status_rate_hz);

/// Listens `listen_s` [s] on `lcm_url`'s CLM_SERVO_STATUS; returns the session
/// of a status (passing decode_checked) of `axis` from a session other than
/// `own_session`, or 0 when none came. Throws std::invalid_argument for a
/// URL that is not udpm, std::runtime_error when the socket cannot be opened.
/// Only a status signed with `key` counts (telemetry/message_mac.hpp): a
/// made-up one cannot keep the daemon from starting.
std::int64_t other_session_of_axis(const std::string& lcm_url, const std::string& axis, std::int64_t own_session,
                                   double listen_s, const HmacSha256& key);

/// other_session_of_axis over presence_window_s(status_rate_hz); throws
/// std::runtime_error naming the axis, the URL and the other session when
/// another daemon drives the axis there.
void require_axis_free(const std::string& lcm_url, const std::string& axis, std::int64_t own_session,
                       double status_rate_hz, const HmacSha256& key);

}  // namespace clm::servod
