#include "commutation/elementary.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

// No fused multiply-add anywhere in this file (-ffp-contract=off in
// CMakeLists.txt, and for Clang the pragma below): every result must stay
// bit-identical whatever the compiler or the CPU may use.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

namespace clm::elementary {
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
// compiles with -ffp-contract=off, and the AVX2 variant does not enable
// FMA): every path gives bit-identical results.
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


namespace {

// expm1(r) on |r| ≤ ln2/2 (≈0.347) for exp: the Taylor series of
// tanh_lanes continued to r^14 (remainder below 1e-17 of |expm1(r)|, where
// tanh_lanes' r^12 leaves up to 5e-16), by Horner's scheme.
double expm1_reduced(double r) noexcept {
  constexpr double kC13 = 1.0 / 6227020800.0, kC14 = 1.0 / 87178291200.0;
  const double q =
      kC2 + r * (kC3 + r * (kC4 + r * (kC5 + r * (kC6 + r * (kC7 + r * (kC8 + r * (kC9 + r * (kC10 +
      r * (kC11 + r * (kC12 + r * (kC13 + r * kC14)))))))))));
  return r + (r * r) * q;
}

// 2^n for −1022 ≤ n ≤ 1023, built from its bits.
double power_of_two(std::int64_t n) noexcept {
  const std::uint64_t bits = static_cast<std::uint64_t>(n + 1023) << 52;
  double value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

// sin and cos of the reduced argument x + y, |x + y| ≤ π/4 (y the low part,
// |y| ≤ ulp(x)/2). Minimax polynomials on [−π/4, π/4] with the published
// coefficients of Sun's fdlibm (k_sin.c, k_cos.c), written for this file.
constexpr double kS1 = -1.66666666666666324348e-01, kS2 = 8.33333333332248946124e-03,
                 kS3 = -1.98412698298579493134e-04, kS4 = 2.75573137070700676789e-06,
                 kS5 = -2.50507602534068634195e-08, kS6 = 1.58969099521155010221e-10;
constexpr double kCos1 = 4.16666666666666019037e-02, kCos2 = -1.38888888888741095749e-03,
                 kCos3 = 2.48015872894767294178e-05, kCos4 = -2.75573143513906633035e-07,
                 kCos5 = 2.08757232129817482790e-09, kCos6 = -1.13596475577881948265e-11;

double sin_reduced(double x, double y) noexcept {
  const double z = x * x;
  const double w = z * z;
  const double r = kS2 + z * (kS3 + z * kS4) + z * w * (kS5 + z * kS6);
  const double v = z * x;
  return x - ((z * (0.5 * y - v * r) - y) - v * kS1);
}

double cos_reduced(double x, double y) noexcept {
  const double z = x * x;
  const double w = z * z;
  const double r = z * (kCos1 + z * (kCos2 + z * kCos3)) + w * w * (kCos4 + z * (kCos5 + z * kCos6));
  const double half_z = 0.5 * z;
  const double one_minus = 1.0 - half_z;
  return one_minus + (((1.0 - one_minus) - half_z) + (z * r - x * y));
}

// π/2 in 33-bit pieces: k·piece is exact for |k| < 2^20.
constexpr double kTwoOverPi = 6.36619772367581382433e-01;
constexpr double kPiOver2Part1 = 1.57079632673412561417e+00;
constexpr double kPiOver2Part2 = 6.07710050630396597660e-11;
constexpr double kPiOver2Part3 = 2.02226624871116645580e-21;
constexpr double kPiOver2Part4 = 8.47842766036889956997e-32;
constexpr double kReductionLimit = 1.6e6;  // |x|·2/π < 2^20

// atan on [0, 7/16] by a minimax polynomial in x², with the breakpoints
// 7/16, 11/16, 19/16, 39/16 and their atan in two parts (fdlibm's s_atan.c).
constexpr double kAtanHigh[] = {4.63647609000806093515e-01, 7.85398163397448278999e-01,
                                9.82793723247329054082e-01, 1.57079632679489655800e+00};
constexpr double kAtanLow[] = {2.26987774529616870924e-17, 3.06161699786838301793e-17,
                               1.39033110312309984516e-17, 6.12323399573676603587e-17};
constexpr double kAtanCoefficient[] = {
    3.33333333333329318027e-01,  -1.99999999998764832476e-01, 1.42857142725034663711e-01,
    -1.11111104054623557880e-01, 9.09088713343650656196e-02,  -7.69187620504482999495e-02,
    6.66107313738753120669e-02,  -5.83357013379057348645e-02, 4.97687799461593236017e-02,
    -3.65315727442169155270e-02, 1.62858201153657823623e-02};
constexpr double kPi = 3.1415926535897931160e+00;
constexpr double kPiLow = 1.2246467991473531772e-16;
constexpr double kPiOver2 = 1.5707963267948965580e+00;
constexpr double kPiOver4 = 7.8539816339744827900e-01;

double atan_nonnegative(double x) noexcept {
  int id = -1;
  if (x >= 0x1p66) return kAtanHigh[3] + kAtanLow[3];
  if (x < 0.4375) {
    if (x < 0x1p-27) return x;
  } else if (x < 1.1875) {
    if (x < 0.6875) {
      id = 0;
      x = (2.0 * x - 1.0) / (2.0 + x);
    } else {
      id = 1;
      x = (x - 1.0) / (x + 1.0);
    }
  } else if (x < 2.4375) {
    id = 2;
    x = (x - 1.5) / (1.0 + 1.5 * x);
  } else {
    id = 3;
    x = -1.0 / x;
  }
  const double* a = kAtanCoefficient;
  const double z = x * x;
  const double w = z * z;
  const double s1 = z * (a[0] + w * (a[2] + w * (a[4] + w * (a[6] + w * (a[8] + w * a[10])))));
  const double s2 = w * (a[1] + w * (a[3] + w * (a[5] + w * (a[7] + w * a[9]))));
  if (id < 0) return x - x * (s1 + s2);
  return kAtanHigh[id] - ((x * (s1 + s2) - kAtanLow[id]) - x);
}

// ln(1 + f) on [√2/2 − 1, √2 − 1] through s = f/(2 + f) and a minimax
// polynomial in s² (fdlibm's e_log.c coefficients).
constexpr double kLog1 = 6.666666666666735130e-01, kLog2 = 3.999999999940941908e-01,
                 kLog3 = 2.857142874366239149e-01, kLog4 = 2.222219843214978396e-01,
                 kLog5 = 1.818357216161805012e-01, kLog6 = 1.531383769920937332e-01,
                 kLog7 = 1.479819860511658591e-01;

}  // namespace

double exp(double x) noexcept {
  if (x != x) return x + x;                        // NaN
  if (x > 709.782712893383973096) return x * 0x1p1023;  // +∞ (and overflow)
  if (x < -745.133219101941108420) return 0.0;          // underflow, −∞
  // e^x = 2^n·e^r, n = round(x/ln 2), |r| ≤ ln2/2 (Cody–Waite, exact for |n| < 2^21).
  const double n = (x * kLog2e + kRoundingShifter) - kRoundingShifter;
  const double r = (x - n * kLn2High) - n * kLn2Low;
  const double mantissa = 1.0 + expm1_reduced(r);
  const auto k = static_cast<std::int64_t>(n);
  if (k > 1023) return mantissa * power_of_two(k - 1023) * 0x1p1023;
  if (k < -1021) return mantissa * power_of_two(k + 1021) * 0x1p-1021;  // one rounding, into the subnormals
  return mantissa * power_of_two(k);
}

double log(double x) noexcept {
  if (x != x) return x + x;
  if (x < 0.0) return std::numeric_limits<double>::quiet_NaN();
  if (x == 0.0) return -std::numeric_limits<double>::infinity();
  if (x == std::numeric_limits<double>::infinity()) return x;
  int exponent = 0;
  double m = std::frexp(x, &exponent);  // exact: x = m·2^exponent, m in [1/2, 1)
  if (m < 0.70710678118654752440) {
    m *= 2.0;
    exponent -= 1;
  }
  const double f = m - 1.0;  // exact (Sterbenz)
  const double k = exponent;
  const double s = f / (2.0 + f);
  const double z = s * s;
  const double w = z * z;
  const double t1 = w * (kLog2 + w * (kLog4 + w * kLog6));
  const double t2 = z * (kLog1 + w * (kLog3 + w * (kLog5 + w * kLog7)));
  const double half_f_square = 0.5 * f * f;
  return k * kLn2High - ((half_f_square - (s * (half_f_square + t1 + t2) + k * kLn2Low)) - f);
}

double tanh(double x) noexcept {
  double y;
  tanh_array(&x, &y, 1);
  return y;
}

namespace {

// x = k·π/2 + (high + low) for π/4 < |x| < kReductionLimit: the remainder as
// a double-double and the quadrant k mod 4.
struct Reduced {
  double high;
  double low;
  std::int64_t quadrant;
};

Reduced reduce(double x) noexcept {
  const double k = (x * kTwoOverPi + kRoundingShifter) - kRoundingShifter;
  const double t = x - k * kPiOver2Part1;  // exact
  const double w = k * kPiOver2Part2;      // exact
  const double r = t - w;
  const double bb = r - t;
  double low = (t - (r - bb)) + (-w - bb);  // the error of t − w (two-sum)
  low -= k * kPiOver2Part3;
  low -= k * kPiOver2Part4;
  const double high = r + low;
  low -= high - r;
  return {high, low, static_cast<std::int64_t>(k) & 3};
}

}  // namespace

// sin, cos and sin_cos share the reduction and the two kernels: sin and cos
// alone give the bits of sin_cos's parts and evaluate one kernel, not both.
SinCos sin_cos(double x) noexcept {
  if (!(std::fabs(x) < kReductionLimit)) {
    if (std::fabs(x) < std::numeric_limits<double>::infinity()) return {std::sin(x), std::cos(x)};
    return {x - x, x - x};  // NaN for ±∞ and NaN
  }
  if (std::fabs(x) <= kPiOver4) return {sin_reduced(x, 0.0), cos_reduced(x, 0.0)};
  const Reduced r = reduce(x);
  const double s = sin_reduced(r.high, r.low);
  const double c = cos_reduced(r.high, r.low);
  switch (r.quadrant) {
    case 0:
      return {s, c};
    case 1:
      return {c, -s};
    case 2:
      return {-s, -c};
    default:
      return {-c, s};
  }
}

namespace {

// sin of `x` advanced by `quarter_turns` quadrants (cos x = sin(x + π/2)):
// sin and cos take the same reduction and the same kernels as sin_cos.
double sin_turned(double x, int quarter_turns) noexcept {
  if (!(std::fabs(x) < kReductionLimit)) {
    if (std::fabs(x) < std::numeric_limits<double>::infinity()) {
      return quarter_turns == 0 ? std::sin(x) : std::cos(x);
    }
    return x - x;
  }
  const Reduced r = std::fabs(x) <= kPiOver4 ? Reduced{x, 0.0, 0} : reduce(x);
  switch ((r.quadrant + quarter_turns) & 3) {
    case 0:
      return sin_reduced(r.high, r.low);
    case 1:
      return cos_reduced(r.high, r.low);
    case 2:
      return -sin_reduced(r.high, r.low);
    default:
      return -cos_reduced(r.high, r.low);
  }
}

}  // namespace

double sin(double x) noexcept { return sin_turned(x, 0); }

double cos(double x) noexcept { return sin_turned(x, 1); }

double atan2(double y, double x) noexcept {
  if (x != x || y != y) return x + y;
  const bool y_negative = std::signbit(y);
  const auto with_sign_of_y = [&](double value) { return y_negative ? -value : value; };
  if (y == 0.0) {
    if (!std::signbit(x)) return y;  // ±0
    return with_sign_of_y(kPi);
  }
  if (x == 0.0) return with_sign_of_y(kPiOver2);
  const double infinity = std::numeric_limits<double>::infinity();
  if (std::fabs(x) == infinity) {
    if (std::fabs(y) == infinity) return with_sign_of_y(x > 0.0 ? kPiOver4 : 3.0 * kPiOver4);
    return with_sign_of_y(x > 0.0 ? 0.0 : kPi);
  }
  if (std::fabs(y) == infinity) return with_sign_of_y(kPiOver2);
  // atan(|y/x|), guarded against overflow and underflow of the quotient.
  const int exponent_difference = std::ilogb(y) - std::ilogb(x);
  double z;
  if (exponent_difference > 60) {
    z = kPiOver2 + 0.5 * kPiLow;
  } else if (x < 0.0 && exponent_difference < -60) {
    z = 0.0;
  } else {
    z = atan_nonnegative(std::fabs(y / x));
  }
  if (x > 0.0) return with_sign_of_y(z);
  return with_sign_of_y(kPi - (z - kPiLow));
}

}  // namespace clm::elementary
