#include "config/sha256.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "config/regular_file.hpp"

namespace clm {
// Named, not anonymous: HmacSha256::Pads, declared in the header, holds a Sha256.
namespace sha256_detail {

constexpr std::array<std::uint32_t, 64> kRound = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

std::uint32_t rotate(std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

void compress(std::array<std::uint32_t, 8>& state, const unsigned char* block) {
  std::uint32_t w[64];
  for (int i = 0; i < 16; ++i) {
    w[i] = (std::uint32_t(block[4 * i]) << 24) | (std::uint32_t(block[4 * i + 1]) << 16) |
           (std::uint32_t(block[4 * i + 2]) << 8) | std::uint32_t(block[4 * i + 3]);
  }
  for (int i = 16; i < 64; ++i) {
    const std::uint32_t s0 = rotate(w[i - 15], 7) ^ rotate(w[i - 15], 18) ^ (w[i - 15] >> 3);
    const std::uint32_t s1 = rotate(w[i - 2], 17) ^ rotate(w[i - 2], 19) ^ (w[i - 2] >> 10);
    w[i] = w[i - 16] + s0 + w[i - 7] + s1;
  }
  auto [a, b, c, d, e, f, g, h] = state;
  for (int i = 0; i < 64; ++i) {
    const std::uint32_t t1 = h + (rotate(e, 6) ^ rotate(e, 11) ^ rotate(e, 25)) + ((e & f) ^ (~e & g)) + kRound[static_cast<std::size_t>(i)] + w[i];
    const std::uint32_t t2 = (rotate(a, 2) ^ rotate(a, 13) ^ rotate(a, 22)) + ((a & b) ^ (a & c) ^ (b & c));
    h = g;
    g = f;
    f = e;
    e = d + t1;
    d = c;
    c = b;
    b = a;
    a = t1 + t2;
  }
  const std::uint32_t add[8] = {a, b, c, d, e, f, g, h};
  for (std::size_t i = 0; i < 8; ++i) state[i] += add[i];
}

/// SHA-256 fed in pieces: the same digest as one call on the concatenation.
class Sha256 {
 public:
  void update(const unsigned char* bytes, std::size_t count) {
    total_ += count;
    if (buffered_ > 0) {
      const std::size_t take = std::min(count, block_.size() - buffered_);
      std::copy_n(bytes, take, block_.data() + buffered_);
      buffered_ += take;
      bytes += take;
      count -= take;
      if (buffered_ < block_.size()) return;
      compress(state_, block_.data());
      buffered_ = 0;
    }
    for (; count >= 64; bytes += 64, count -= 64) compress(state_, bytes);
    std::copy_n(bytes, count, block_.data());
    buffered_ = count;
  }

  Sha256Digest finish_bytes() {
    unsigned char tail[128] = {};
    const std::size_t rest = buffered_;
    std::copy_n(block_.data(), rest, tail);
    tail[rest] = 0x80;
    const std::size_t tail_size = rest + 9 <= 64 ? 64 : 128;
    const std::uint64_t bits = total_ * 8;
    for (int i = 0; i < 8; ++i) tail[tail_size - 1 - static_cast<std::size_t>(i)] = static_cast<unsigned char>(bits >> (8 * i));
    for (std::size_t i = 0; i < tail_size; i += 64) compress(state_, tail + i);
    Sha256Digest digest;
    for (std::size_t w = 0; w < 8; ++w) {
      for (std::size_t i = 0; i < 4; ++i) digest[4 * w + i] = static_cast<std::uint8_t>(state_[w] >> (24 - 8 * i));
    }
    return digest;
  }

  std::string finish() {
    static constexpr char kHex[] = "0123456789abcdef";
    std::string hex;
    for (std::uint8_t byte : finish_bytes()) {
      hex += kHex[byte >> 4];
      hex += kHex[byte & 0xf];
    }
    return hex;
  }

 private:
  std::array<std::uint32_t, 8> state_ = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                                         0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  std::array<unsigned char, 64> block_{};
  std::size_t buffered_ = 0;
  std::uint64_t total_ = 0;
};

}  // namespace sha256_detail

using sha256_detail::Sha256;

struct HmacSha256::Pads {
  Sha256 inner;  ///< after the key XOR ipad block
  Sha256 outer;  ///< after the key XOR opad block
};

HmacSha256::HmacSha256(std::span<const std::uint8_t> key) {
  auto pads = std::make_shared<Pads>();
  // RFC 2104: a key longer than the block is hashed first; shorter ones are
  // padded with zeros to the 64-byte block.
  std::array<unsigned char, 64> block{};
  if (key.size() > block.size()) {
    Sha256 hash;
    hash.update(key.data(), key.size());
    const Sha256Digest digest = hash.finish_bytes();
    std::copy(digest.begin(), digest.end(), block.begin());
  } else {
    std::copy(key.begin(), key.end(), block.begin());
  }
  std::array<unsigned char, 64> pad{};
  for (std::size_t i = 0; i < block.size(); ++i) pad[i] = block[i] ^ 0x36;
  pads->inner.update(pad.data(), pad.size());
  for (std::size_t i = 0; i < block.size(); ++i) pad[i] = block[i] ^ 0x5c;
  pads->outer.update(pad.data(), pad.size());
  pads_ = std::move(pads);
}

Sha256Digest HmacSha256::mac(std::initializer_list<std::span<const std::uint8_t>> parts) const noexcept {
  Sha256 inner = pads_->inner;
  for (const auto& part : parts) inner.update(part.data(), part.size());
  const Sha256Digest inner_digest = inner.finish_bytes();
  Sha256 outer = pads_->outer;
  outer.update(inner_digest.data(), inner_digest.size());
  return outer.finish_bytes();
}

bool equal_in_constant_time(std::span<const std::uint8_t> a, std::span<const std::uint8_t> b) noexcept {
  if (a.size() != b.size()) return false;
  std::uint8_t difference = 0;
  for (std::size_t i = 0; i < a.size(); ++i) difference |= static_cast<std::uint8_t>(a[i] ^ b[i]);
  return difference == 0;
}

std::string sha256_hex(std::string_view data) {
  Sha256 hash;
  hash.update(reinterpret_cast<const unsigned char*>(data.data()), data.size());
  return hash.finish();
}

std::string sha256_file(const std::string& path) {
  // Streamed in blocks: a data file of gigabytes costs no memory here. Only a
  // regular file (clm::open_regular_file), of any size.
  RegularFile file = open_regular_file(path, kUnlimitedBytes);
  Sha256 hash;
  std::vector<unsigned char> buffer(1 << 20);
  while (const std::size_t got = file.read(buffer.data(), buffer.size())) hash.update(buffer.data(), got);
  return hash.finish();
}

}  // namespace clm
