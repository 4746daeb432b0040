#include "drivers/sim/random.hpp"

#include <cmath>

#include "commutation/elementary.hpp"
#include "commutation/types.hpp"

namespace clm::sim {
namespace {
std::uint64_t rotate_left(std::uint64_t x, int k) noexcept { return (x << k) | (x >> (64 - k)); }
}  // namespace

std::uint64_t splitmix64(std::uint64_t& state) noexcept {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t stream) noexcept {
  std::uint64_t state = seed;
  const std::uint64_t mixed_seed = splitmix64(state);
  state = mixed_seed ^ (stream * 0xD1B54A32D192ED03ULL);
  return splitmix64(state);
}

RandomStream::RandomStream(std::uint64_t seed) noexcept {
  std::uint64_t state = seed;
  for (auto& word : state_) word = splitmix64(state);
}

std::uint64_t RandomStream::next_u64() noexcept {
  const std::uint64_t result = rotate_left(state_[1] * 5, 7) * 9;
  const std::uint64_t t = state_[1] << 17;
  state_[2] ^= state_[0];
  state_[3] ^= state_[1];
  state_[1] ^= state_[2];
  state_[0] ^= state_[3];
  state_[2] ^= t;
  state_[3] = rotate_left(state_[3], 45);
  return result;
}

double RandomStream::uniform() noexcept { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

double RandomStream::normal() noexcept {
  if (has_spare_normal_) {
    has_spare_normal_ = false;
    return spare_normal_;
  }
  // 1 − u lies in (0, 1], so the logarithm is finite.
  const double radius = std::sqrt(-2.0 * elementary::log(1.0 - uniform()));
  const double angle = kTwoPi * uniform();
  const auto [s, c] = elementary::sin_cos(angle);
  spare_normal_ = radius * s;
  has_spare_normal_ = true;
  return radius * c;
}

}  // namespace clm::sim
