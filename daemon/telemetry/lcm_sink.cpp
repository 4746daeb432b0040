#include "daemon/telemetry/lcm_sink.hpp"

#include <lcm/lcm-cpp.hpp>

#include <stdexcept>

namespace clm::telemetry {

std::string with_receive_buffer(const std::string& url) {
  if (url.rfind("udpm://", 0) != 0 || url.find("recv_buf_size=") != std::string::npos) return url;
  return url + (url.find('?') == std::string::npos ? "?" : "&") + "recv_buf_size=4194304";
}

void LcmSink::publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t /*utime*/) {
  const std::string name(channel);
  if (lcm_.publish(name, data.data(), static_cast<unsigned int>(data.size())) != 0) {
    throw std::runtime_error("LCM: cannot publish " + std::to_string(data.size()) + " bytes on " + name);
  }
}

}  // namespace clm::telemetry
