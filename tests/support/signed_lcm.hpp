#pragma once
// Messages signed with an operators' key as clm-servod and its clients sign
// them (daemon/telemetry/message_mac.hpp), for tests that play one side.

#include <lcm/lcm-cpp.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "config/sha256.hpp"
#include "daemon/telemetry/message_mac.hpp"

namespace clm::test {

/// A key made of `text`'s bytes (at least 32 of them for a key file's rules).
inline HmacSha256 key_of(const std::string& text) {
  return HmacSha256(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

/// Publishes `message` on `channel` with the mac of `key`, or with its mac
/// left zero when `key` is nullptr (what anyone without the key can send).
template <typename Message>
int publish_signed(lcm::LCM& lcm, const std::string& channel, const Message& message, const HmacSha256* key) {
  std::vector<std::uint8_t> encoded(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(encoded.data(), 0, static_cast<int>(encoded.size()));
  if (key != nullptr) telemetry::sign_encoded(*key, channel, encoded);
  return lcm.publish(channel, encoded.data(), static_cast<unsigned int>(encoded.size()));
}

}  // namespace clm::test
