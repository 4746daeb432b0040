#pragma once
// Keeping telemetry in memory (tests, simulation).

#include <cstdint>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "daemon/telemetry/sink.hpp"

namespace clm::telemetry {

/// Keeps every message in memory. Thread-safe.
class MemorySink : public TelemetrySink {
 public:
  struct Event {
    std::string channel;
    std::int64_t utime = 0;
    std::vector<std::uint8_t> data;
  };

  void publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) override;
  std::vector<Event> events() const;
  std::size_t size() const;

  /// Every message on `channel`, decoded as `Message`; throws
  /// std::runtime_error naming the event when one does not decode.
  template <typename Message>
  std::vector<Message> decode(std::string_view channel) const {
    std::vector<Message> result;
    const auto all = events();
    for (std::size_t i = 0; i < all.size(); ++i) {
      if (all[i].channel != channel) continue;
      Message message;
      const int size = static_cast<int>(all[i].data.size());
      if (message.decode(all[i].data.data(), 0, size) != size) {
        throw std::runtime_error("memory sink: event " + std::to_string(i) + ": cannot decode " + std::string(channel));
      }
      result.push_back(std::move(message));
    }
    return result;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<Event> events_;
};

}  // namespace clm::telemetry
