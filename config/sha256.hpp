#pragma once
// SHA-256 (FIPS 180-4) of data files, recorded in model and calibration
// provenance, and HMAC-SHA256 (RFC 2104), which authenticates the daemon's
// commands and telemetry with the operators' key (config/command_key.hpp).

#include <array>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <span>
#include <string>
#include <string_view>

namespace clm {

using Sha256Digest = std::array<std::uint8_t, 32>;

/// Lower-case hex SHA-256 of `data`.
std::string sha256_hex(std::string_view data);
/// SHA-256 of a regular file's bytes, read in blocks; throws std::runtime_error
/// (clm::FileError) if it is not a regular file or cannot be read.
std::string sha256_file(const std::string& path);

/// HMAC-SHA256 with one key. The key's padded blocks are hashed once, here;
/// mac() then costs the message's blocks and two more. Copies share the key
/// state; mac() is const and may run on several threads at once.
class HmacSha256 {
 public:
  explicit HmacSha256(std::span<const std::uint8_t> key);
  /// The MAC of the concatenation of `parts`.
  Sha256Digest mac(std::initializer_list<std::span<const std::uint8_t>> parts) const noexcept;

 private:
  struct Pads;
  std::shared_ptr<const Pads> pads_;
};

/// a == b, in a time that does not depend on where they differ.
bool equal_in_constant_time(std::span<const std::uint8_t> a, std::span<const std::uint8_t> b) noexcept;

}  // namespace clm
