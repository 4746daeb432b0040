#pragma once
// Deterministic random numbers for the simulator. The same seed gives the same
// sequence with every compiler and standard library: std::normal_distribution
// and friends are implementation-defined, so they are not used.

#include <cstdint>

namespace clm::sim {

/// One step of splitmix64 on `state`; used to expand seeds.
std::uint64_t splitmix64(std::uint64_t& state) noexcept;

/// A seed for the independent stream `stream` of a simulation seeded with
/// `seed`. Each parasitic draws from its own stream, so switching one off or
/// resizing it leaves the random draws of all others unchanged.
std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t stream) noexcept;

/// xoshiro256** generator with uniform and standard normal draws. No allocation.
class RandomStream {
 public:
  explicit RandomStream(std::uint64_t seed) noexcept;

  std::uint64_t next_u64() noexcept;
  /// Uniform in [0, 1) with 53 random bits.
  double uniform() noexcept;
  /// Standard normal N(0, 1) (Box–Muller; the second value of a pair is kept
  /// for the next call).
  double normal() noexcept;

 private:
  std::uint64_t state_[4];
  double spare_normal_ = 0.0;
  bool has_spare_normal_ = false;
};

}  // namespace clm::sim
