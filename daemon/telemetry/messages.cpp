#include "daemon/telemetry/messages.hpp"

#include <chrono>

namespace clm::telemetry {

std::int64_t wall_clock_utime() noexcept {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace clm::telemetry
