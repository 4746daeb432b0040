#pragma once
// Publishing on an LCM instance (udpm multicast, docs/telemetry.md).

#include <string>

#include "daemon/telemetry/sink.hpp"

namespace lcm {
class LCM;
}

namespace clm::telemetry {

/// `url` with a 4 MiB kernel receive buffer asked for (LCM's udpm option
/// recv_buf_size, capped by net.core.rmem_max) when it is udpm and does not
/// set one. Every udpm receiver on the port also receives the daemon's
/// states (about 1 KiB of socket buffer each, datagram overhead included);
/// the default 208 KiB then holds some 200 ms of them, and a receiver
/// descheduled longer on a loaded host lost states, and commands with them.
std::string with_receive_buffer(const std::string& url);

/// Publishes on an LCM instance the caller owns.
class LcmSink : public TelemetrySink {
 public:
  explicit LcmSink(lcm::LCM& lcm) : lcm_(lcm) {}
  /// Throws std::runtime_error when LCM refuses the message (e.g. no route
  /// for the multicast group).
  void publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) override;

 private:
  lcm::LCM& lcm_;
};

}  // namespace clm::telemetry
