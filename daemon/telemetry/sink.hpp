#pragma once
// Where telemetry goes: LCM (lcm_sink.hpp), an LCM log (lcm_log_writer.hpp),
// memory (memory_sink.hpp): drake's pattern, LCM behind an interface with a
// log implementation, so tests need no network.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace clm::telemetry {

class TelemetrySink {
 public:
  virtual ~TelemetrySink() = default;
  /// One encoded message on `channel`, stamped `utime` [µs since the UNIX
  /// epoch]. May throw std::runtime_error; the publisher counts the failure.
  virtual void publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) = 0;
};

/// Encodes `message` (a clm_lcm type) and publishes it on `sink`.
template <typename Message>
void publish_message(TelemetrySink& sink, std::string_view channel, const Message& message, std::int64_t utime) {
  std::vector<std::uint8_t> buffer(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
  sink.publish(channel, buffer, utime);
}

}  // namespace clm::telemetry
