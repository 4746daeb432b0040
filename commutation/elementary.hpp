#pragma once
// Elementary functions whose results do not depend on the CPU.
//
// glibc picks its exp, log, sin, cos, tanh and atan2 at run time by the CPU's
// features (FMA/AVX2 variants or the baseline): on x86-64 the two give
// different last bits for a sizeable share of arguments. The PGNN's training
// and selection turn on such bits (docs/commutation.md, "Reproducibility"), so
// every number the simulator, the identification and the laws compute goes
// through these functions instead: plain double arithmetic in a fixed order,
// no fused multiply-add, no call into libm, compiled once for the x86-64
// baseline. The same inputs give the same bits on every x86-64 CPU.
//
// Accuracy: within 1 ulp of the exact result (tested against long double
// over dense grids, tests/commutation/test_elementary.cpp). ±∞ and NaN give
// what the C library's functions give. No allocation, no exception: the
// cycle calls them.

namespace clm::elementary {

/// e^x. Overflows to +∞ above 709.78, underflows to 0 below −745.13.
double exp(double x) noexcept;

/// Natural logarithm; −∞ at ±0, NaN below 0.
double log(double x) noexcept;

/// tanh(x) (the same kernel as tanh_array, one value).
double tanh(double x) noexcept;

/// sin x and cos x together. Arguments are reduced by π/2 in three parts,
/// exact for |x| < 1.6·10⁶ rad; beyond that (no angle of this project comes
/// near it) the C library's sin and cos are used.
struct SinCos {
  double sin;
  double cos;
};
SinCos sin_cos(double x) noexcept;
/// sin x alone and cos x alone: bit for bit sin_cos(x).sin and sin_cos(x).cos,
/// at about half the cost.
double sin(double x) noexcept;
double cos(double x) noexcept;

/// The angle of (x, y) in (−π, π], with the C library's conventions for
/// zeros and infinities.
double atan2(double y, double x) noexcept;

/// tanh of `count` values: out[k] = tanh(in[k]) (`out` may be `in`),
/// several lanes at a time (SSE2, or AVX2 where the CPU has it, chosen at run
/// time; both give bit-identical results). ±0 and the sign are kept, ±∞
/// gives ±1, NaN stays NaN. The cycle's networks use it.
void tanh_array(const double* in, double* out, int count) noexcept;

namespace detail {
/// tanh_array on the baseline path (2 lanes), whatever the CPU; for tests.
void tanh_array_baseline(const double* in, double* out, int count) noexcept;
/// Whether tanh_array takes the AVX2 path on this CPU.
bool tanh_array_uses_avx2() noexcept;
}  // namespace detail

}  // namespace clm::elementary
