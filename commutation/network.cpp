#include "commutation/network.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>

// No fused multiply-add anywhere in this file (GCC: -std=c++20 implies
// -ffp-contract=off; Clang contracts by default): the tanh paths must stay
// bit-identical whatever the compiler may use.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

namespace clm {
namespace {

// Lanes as GCC/Clang generic vectors, 2 (one SSE2 register, the x86-64
// baseline; or one NEON register) or 4 (one AVX2 register, chosen at run
// time). Bit manipulation on unsigned lanes (no signed overflow).
typedef double Lanes2 __attribute__((vector_size(16)));
typedef std::uint64_t LaneBits2 __attribute__((vector_size(16)));
typedef double Lanes4 __attribute__((vector_size(32)));
typedef std::uint64_t LaneBits4 __attribute__((vector_size(32)));

constexpr std::uint64_t kSignBit = 0x8000000000000000ULL;
// Beyond this, tanh rounds to ±1 (1 − tanh(x) ≈ 2e^{−2x} < 2^−54 from x ≈ 19.1);
// the clamp keeps e^{2|x|} finite.
constexpr double kSaturation = 22.0;
// Adding 1.5·2^52 rounds a double of magnitude < 2^51 to an integer, which
// then sits in the low bits of the sum's mantissa.
constexpr double kRoundingShifter = 0x1.8p52;
constexpr double kLog2e = 1.4426950408889634074;
// ln 2 split so that n·kLn2High is exact for |n| < 2^21 (Cody–Waite reduction).
constexpr double kLn2High = 6.93147180369123816490e-01;
constexpr double kLn2Low = 1.90821492927058770002e-10;
// 1/k!: the Taylor series of expm1 on |r| ≤ ln2/2 up to r^12, whose
// remainder is below 5e-16 of |expm1(r)|.
constexpr double kC2 = 1.0 / 2, kC3 = 1.0 / 6, kC4 = 1.0 / 24, kC5 = 1.0 / 120, kC6 = 1.0 / 720,
                 kC7 = 1.0 / 5040, kC8 = 1.0 / 40320, kC9 = 1.0 / 362880, kC10 = 1.0 / 3628800,
                 kC11 = 1.0 / 39916800, kC12 = 1.0 / 479001600;

// tanh(x) = sign(x)·e/(e + 2) with e = expm1(2|x|), for one vector of lanes:
// no cancellation for small |x| (e has full relative precision there), one
// division, and a short dependency chain (Estrin's scheme) so that
// consecutive vectors overlap in the pipeline. The same operations in the
// same order for every lane width and no fused multiply-add (the project
// compiles with -std=c++20, i.e. -ffp-contract=off, and the AVX2 variant
// does not enable FMA): every path gives bit-identical results.
template <typename Lanes, typename LaneBits>
[[gnu::always_inline]] inline void tanh_lanes(const double* in, double* out) noexcept {
  const Lanes saturation = Lanes{} + kSaturation;
  const Lanes shifter = Lanes{} + kRoundingShifter;
  Lanes x;
  std::memcpy(&x, in, sizeof x);
  const LaneBits bits = (LaneBits)x;
  const LaneBits sign = bits & kSignBit;
  Lanes a = (Lanes)(bits & ~kSignBit);
  // NaN fails the comparison and stays NaN; +∞ is clamped.
  const LaneBits saturated = (LaneBits)(a > saturation);
  a = (Lanes)(((LaneBits)a & ~saturated) | ((LaneBits)saturation & saturated));
  const Lanes y = a + a;  // ≥ 0
  // e^y = 2^n·e^r, n = round(y/ln 2), |r| ≤ ln2/2.
  const Lanes shifted = y * kLog2e + shifter;
  const Lanes n = shifted - shifter;
  const LaneBits exponent = (LaneBits)shifted - (LaneBits)shifter + 1023U;
  const Lanes scale = (Lanes)(exponent << 52);  // 2^n, 0 ≤ n ≤ 64
  const Lanes r = (y - n * kLn2High) - n * kLn2Low;
  // expm1(r) = r + r²·q(r), q = Σ_{k=2..12} r^{k−2}/k!, by Estrin's scheme.
  const Lanes r2 = r * r;
  const Lanes r4 = r2 * r2;
  const Lanes r8 = r4 * r4;
  const Lanes q01 = (kC2 + kC3 * r) + (kC4 + kC5 * r) * r2;
  const Lanes q23 = (kC6 + kC7 * r) + (kC8 + kC9 * r) * r2;
  const Lanes q45 = (kC10 + kC11 * r) + kC12 * r2;
  const Lanes q = (q01 + q23 * r4) + q45 * r8;
  const Lanes expm1_r = r + r2 * q;
  // e^y − 1 = 2^n·expm1(r) + (2^n − 1); exact for n = 0.
  const Lanes e = scale * expm1_r + (scale - 1.0);
  const Lanes magnitude = e / (e + 2.0);
  const Lanes result = (Lanes)((LaneBits)magnitude | sign);
  std::memcpy(out, &result, sizeof result);
}

// The last 0 or 1 values.
[[gnu::always_inline]] inline void tanh_tail(const double* in, double* out, int count) noexcept {
  if (count > 0) {
    double tail[2] = {in[0], 0.0};
    tanh_lanes<Lanes2, LaneBits2>(tail, tail);
    out[0] = tail[0];
  }
}

#if defined(__x86_64__) || defined(__i386__)
[[gnu::target("avx2")]] void tanh_array_avx2(const double* in, double* out, int count) noexcept {
  int k = 0;
  for (; k + 8 <= count; k += 8) {
    tanh_lanes<Lanes4, LaneBits4>(in + k, out + k);
    tanh_lanes<Lanes4, LaneBits4>(in + k + 4, out + k + 4);
  }
  for (; k + 4 <= count; k += 4) tanh_lanes<Lanes4, LaneBits4>(in + k, out + k);
  for (; k + 2 <= count; k += 2) tanh_lanes<Lanes2, LaneBits2>(in + k, out + k);
  tanh_tail(in + k, out + k, count - k);
}

bool cpu_has_avx2() noexcept {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}

// Set before main; a call during another file's static initialisation sees
// false and takes the baseline path, which gives the same results.
const bool kUseAvx2 = cpu_has_avx2();
#else
constexpr bool kUseAvx2 = false;
#endif

}  // namespace

namespace detail {

void tanh_array_baseline(const double* in, double* out, int count) noexcept {
  int k = 0;
  for (; k + 4 <= count; k += 4) {
    tanh_lanes<Lanes2, LaneBits2>(in + k, out + k);
    tanh_lanes<Lanes2, LaneBits2>(in + k + 2, out + k + 2);
  }
  for (; k + 2 <= count; k += 2) tanh_lanes<Lanes2, LaneBits2>(in + k, out + k);
  tanh_tail(in + k, out + k, count - k);
}

bool tanh_array_uses_avx2() noexcept { return kUseAvx2; }

}  // namespace detail

void tanh_array(const double* in, double* out, int count) noexcept {
#if defined(__x86_64__) || defined(__i386__)
  if (kUseAvx2) {
    tanh_array_avx2(in, out, count);
    return;
  }
#endif
  detail::tanh_array_baseline(in, out, count);
}

Network Network::zeros(const std::vector<int>& hidden_sizes) {
  Network network;
  int previous = 1;
  for (int width : hidden_sizes) {
    network.layers.push_back({Eigen::MatrixXd::Zero(width, previous), Eigen::VectorXd::Zero(width)});
    previous = width;
  }
  network.layers.push_back({Eigen::MatrixXd::Zero(kOutputSize, previous), Eigen::VectorXd::Zero(kOutputSize)});
  return network;
}

std::vector<int> Network::hidden_sizes() const {
  std::vector<int> sizes;
  for (std::size_t i = 0; i + 1 < layers.size(); ++i) sizes.push_back(static_cast<int>(layers[i].biases.size()));
  return sizes;
}

int Network::parameter_count() const {
  int count = 0;
  for (const auto& layer : layers) count += static_cast<int>(layer.weights.size() + layer.biases.size());
  return count;
}

Eigen::Vector3d Network::evaluate(double input) const noexcept {
  if (layers.empty()) return Eigen::Vector3d::Zero();
  // Raw stack buffers and Eigen maps: no allocation, no dynamic-size bookkeeping.
  alignas(16) double activation[kMaxWidth];
  alignas(16) double sum[kMaxWidth];
  activation[0] = input;
  Eigen::Index width = 1;
  const std::size_t hidden = layers.size() - 1;
  for (std::size_t i = 0; i < hidden; ++i) {
    const auto& layer = layers[i];
    const Eigen::Index rows = layer.weights.rows();
    const double* w = layer.weights.data();  // column-major, rows × width
    const double* b = layer.biases.data();
    for (Eigen::Index r = 0; r < rows; ++r) sum[r] = b[r];
    for (Eigen::Index c = 0; c < width; ++c) {
      const double x = activation[c];
      const double* column = w + c * rows;
      for (Eigen::Index r = 0; r < rows; ++r) sum[r] += column[r] * x;
    }
    tanh_array(sum, activation, static_cast<int>(rows));
    width = rows;
  }
  const auto& last = layers.back();
  const double* w = last.weights.data();  // 3 × width, column-major
  double out0 = last.biases[0], out1 = last.biases[1], out2 = last.biases[2];
  for (Eigen::Index c = 0; c < width; ++c) {
    const double x = activation[c];
    out0 += w[3 * c] * x;
    out1 += w[3 * c + 1] * x;
    out2 += w[3 * c + 2] * x;
  }
  return {out0, out1, out2};
}

std::string Network::shape_error() const {
  if (layers.empty()) return {};
  Eigen::Index previous = 1;
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const auto& layer = layers[i];
    const bool last = i + 1 == layers.size();
    const std::string where = "layer " + std::to_string(i + 1);
    if (layer.weights.cols() != previous) {
      return where + ": weights have " + std::to_string(layer.weights.cols()) + " columns, expected " +
             std::to_string(previous);
    }
    if (layer.biases.size() != layer.weights.rows()) {
      return where + ": " + std::to_string(layer.biases.size()) + " biases for " +
             std::to_string(layer.weights.rows()) + " neurons";
    }
    if (last && layer.weights.rows() != kOutputSize) {
      return where + " (output): " + std::to_string(layer.weights.rows()) + " outputs, expected 3";
    }
    if (!last && (layer.weights.rows() < 1 || layer.weights.rows() > kMaxWidth)) {
      return where + ": width " + std::to_string(layer.weights.rows()) + " outside 1.." + std::to_string(kMaxWidth);
    }
    if (!layer.weights.allFinite() || !layer.biases.allFinite()) return where + ": non-finite parameter";
    previous = layer.weights.rows();
  }
  return {};
}

}  // namespace clm
