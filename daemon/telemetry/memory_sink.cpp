#include "daemon/telemetry/memory_sink.hpp"

#include "daemon/telemetry/messages.hpp"

namespace clm::telemetry {

void MemorySink::publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) {
  Event event{std::string(channel), stamped(utime), std::vector<std::uint8_t>(data.begin(), data.end())};
  const std::lock_guard lock(mutex_);
  events_.push_back(std::move(event));
}

std::vector<MemorySink::Event> MemorySink::events() const {
  const std::lock_guard lock(mutex_);
  return events_;
}

std::size_t MemorySink::size() const {
  const std::lock_guard lock(mutex_);
  return events_.size();
}

}  // namespace clm::telemetry
