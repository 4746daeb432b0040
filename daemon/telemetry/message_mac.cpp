#include "daemon/telemetry/message_mac.hpp"

namespace clm::telemetry {
namespace {

constexpr std::size_t kHashBytes = 8;  // every LCM encoding starts with its type's hash
constexpr std::uint8_t kSeparator[1] = {0};

Sha256Digest mac_of(const HmacSha256& key, std::string_view channel, std::span<const std::uint8_t> body) {
  const std::span<const std::uint8_t> name(reinterpret_cast<const std::uint8_t*>(channel.data()), channel.size());
  return key.mac({name, std::span<const std::uint8_t>(kSeparator), body});
}

}  // namespace

bool sign_encoded(const HmacSha256& key, std::string_view channel, std::span<std::uint8_t> encoded) noexcept {
  if (encoded.size() < kHashBytes + kMacBytes) return false;
  const std::size_t body = encoded.size() - kMacBytes;
  const Sha256Digest mac = mac_of(key, channel, encoded.first(body));
  for (std::size_t i = 0; i < kMacBytes; ++i) encoded[body + i] = mac[i];
  return true;
}

bool verify_encoded(const HmacSha256& key, std::string_view channel, std::span<const std::uint8_t> encoded) noexcept {
  if (encoded.size() < kHashBytes + kMacBytes) return false;
  const std::size_t body = encoded.size() - kMacBytes;
  const Sha256Digest mac = mac_of(key, channel, encoded.first(body));
  return equal_in_constant_time(mac, encoded.subspan(body));
}

}  // namespace clm::telemetry
