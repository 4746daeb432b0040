#pragma once
// The MAC of a clm_lcm message (docs/servod.md, "Who may command the axis"):
// every message type ends in `byte mac[32]`, the HMAC-SHA256 with the
// operators' key (config/command_key.hpp) of the channel's name, one NUL byte
// and the message's encoding up to the mac field. The daemon signs what it
// publishes and verifies every command but a stop, quick stop or disable;
// its clients verify what they read. Keyed to the channel, an ack cannot be
// replayed as a status; the session, client and sequence inside the message
// keep a replay from answering another command. Any thread; no allocation.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "config/sha256.hpp"

namespace clm::telemetry {

inline constexpr std::size_t kMacBytes = 32;

/// Writes the MAC of `encoded` for `channel` into its last kMacBytes. False
/// (nothing written) when `encoded` is shorter than the hash and the MAC.
bool sign_encoded(const HmacSha256& key, std::string_view channel, std::span<std::uint8_t> encoded) noexcept;

/// True when the last kMacBytes of `encoded` are the MAC of the rest for `channel`.
bool verify_encoded(const HmacSha256& key, std::string_view channel, std::span<const std::uint8_t> encoded) noexcept;

}  // namespace clm::telemetry
