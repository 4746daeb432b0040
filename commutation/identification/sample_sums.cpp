#include "commutation/identification/sample_sums.hpp"

#include <algorithm>
#include <cstring>

// No fused multiply-add anywhere in this file (-ffp-contract=off in
// CMakeLists.txt, and for Clang the pragma below): an entry's bits must not
// depend on the path that computed it.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

namespace clm::identification {
namespace {

using detail::SampleSumsPath;

// Samples per pass over the tiles: a pass's rows stay in the L2 cache while
// every tile reads them. Only speed depends on it: each entry carries its sum
// from one pass to the next.
constexpr Eigen::Index kPassRows = 64;

// Where the samples and the sum are, for the kernels.
struct Pass {
  const double* samples;  // row t at samples + t·stride
  Eigen::Index stride;
  Eigen::Index count;
  double* sum;  // row i at sum + i·sum_stride
  Eigen::Index sum_stride;
};

// The definition, entry by entry: rows [i0, i0 + ni) × columns [j0, j1).
void entries(const Pass& pass, int i0, int ni, int j0, int j1) {
  for (int i = i0; i < i0 + ni; ++i) {
    for (int j = j0; j < j1; ++j) {
      double acc = pass.sum[i * pass.sum_stride + j];
      for (Eigen::Index t = 0; t < pass.count; ++t) {
        const double* row = pass.samples + t * pass.stride;
        acc += row[i] * row[j];
      }
      pass.sum[i * pass.sum_stride + j] = acc;
    }
  }
}

// Lanes as GCC/Clang generic vectors (as in elementary.cpp): 2 lanes on the
// x86-64 baseline (SSE2), 4 with AVX2, 8 with AVX-512F.
typedef double Lanes2 __attribute__((vector_size(16)));
typedef double Lanes4 __attribute__((vector_size(32)));

// The helpers and tiles below pass vectors by value; they are always
// inlined, so no call ever passes one across the ABI GCC warns about.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
template <typename Lanes>
[[gnu::always_inline]] inline Lanes splat(double x) {
  Lanes v;
  for (int k = 0; k < static_cast<int>(sizeof(Lanes) / sizeof(double)); ++k) v[k] = x;
  return v;
}
template <typename Lanes>
[[gnu::always_inline]] inline Lanes load(const double* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <typename Lanes>
[[gnu::always_inline]] inline void store(double* p, Lanes v) {
  std::memcpy(p, &v, sizeof v);
}

// Rows [i0, i0 + 4) × columns [j0, j0 + 2·L) in eight accumulators, each
// entry a lane: per sample one multiply and one add per entry, as entries()
// does. The accumulators are named, not an array, so that they stay in
// registers at every optimisation level (eight, the loads and a product fit
// in the 16 vector registers of x86-64).
template <typename Lanes>
[[gnu::always_inline]] inline void tile_4x2(const Pass& pass, int i0, int j0) {
  constexpr int L = sizeof(Lanes) / sizeof(double);
  double* s0 = pass.sum + i0 * pass.sum_stride + j0;
  double* s1 = s0 + pass.sum_stride;
  double* s2 = s1 + pass.sum_stride;
  double* s3 = s2 + pass.sum_stride;
  Lanes c00 = load<Lanes>(s0), c01 = load<Lanes>(s0 + L);
  Lanes c10 = load<Lanes>(s1), c11 = load<Lanes>(s1 + L);
  Lanes c20 = load<Lanes>(s2), c21 = load<Lanes>(s2 + L);
  Lanes c30 = load<Lanes>(s3), c31 = load<Lanes>(s3 + L);
  for (Eigen::Index t = 0; t < pass.count; ++t) {
    const double* row = pass.samples + t * pass.stride;
    const Lanes b0 = load<Lanes>(row + j0), b1 = load<Lanes>(row + j0 + L);
    Lanes a = splat<Lanes>(row[i0]);
    c00 += a * b0, c01 += a * b1;
    a = splat<Lanes>(row[i0 + 1]);
    c10 += a * b0, c11 += a * b1;
    a = splat<Lanes>(row[i0 + 2]);
    c20 += a * b0, c21 += a * b1;
    a = splat<Lanes>(row[i0 + 3]);
    c30 += a * b0, c31 += a * b1;
  }
  store(s0, c00), store(s0 + L, c01);
  store(s1, c10), store(s1 + L, c11);
  store(s2, c20), store(s2 + L, c21);
  store(s3, c30), store(s3 + L, c31);
}

// Row i × columns [j0, j0 + L): the rows left over from groups of four.
template <typename Lanes>
[[gnu::always_inline]] inline void tile_1x1(const Pass& pass, int i, int j0) {
  double* s = pass.sum + i * pass.sum_stride + j0;
  Lanes c = load<Lanes>(s);
  for (Eigen::Index t = 0; t < pass.count; ++t) {
    const double* row = pass.samples + t * pass.stride;
    c += splat<Lanes>(row[i]) * load<Lanes>(row + j0);
  }
  store(s, c);
}

// One pass: rows [first, last) of the lower triangle, four rows at a time
// and then one at a time; a row group's columns by the widest tiles that fit
// in the sum's width (the last may reach above the diagonal), the rest entry
// by entry.
template <typename Lanes>
[[gnu::always_inline]] inline void lower_gram_pass(const Pass& pass, int first, int last, int width) {
  constexpr int L = sizeof(Lanes) / sizeof(double);
  int i0 = first;
  for (; i0 + 4 <= last; i0 += 4) {
    const int j_end = i0 + 4;  // columns 0..j_end−1 reach the diagonal
    int j0 = 0;
    for (; j0 < j_end && j0 + 2 * L <= width; j0 += 2 * L) tile_4x2<Lanes>(pass, i0, j0);
    if (j0 < j_end) entries(pass, i0, 4, j0, j_end);
  }
  for (int i = i0; i < last; ++i) {
    int j0 = 0;
    for (; j0 <= i && j0 + L <= width; j0 += L) tile_1x1<Lanes>(pass, i, j0);
    if (j0 <= i) entries(pass, i, 1, j0, i + 1);
  }
}

template <typename Lanes>
[[gnu::always_inline]] inline void lower_gram(const Eigen::Ref<const SampleRows>& samples, int first, int last,
                                              SampleRows& sum) {
  const auto width = static_cast<int>(samples.cols());
  for (Eigen::Index begin = 0; begin < samples.rows(); begin += kPassRows) {
    const Pass pass{samples.data() + begin * samples.outerStride(), samples.outerStride(),
                    std::min(kPassRows, samples.rows() - begin), sum.data(), sum.outerStride()};
    lower_gram_pass<Lanes>(pass, first, last, width);
  }
}

#if defined(__x86_64__)
typedef double Lanes8 __attribute__((vector_size(64)));

[[gnu::target("avx512f")]] void lower_gram_avx512(const Eigen::Ref<const SampleRows>& samples, int first, int last,
                                                  SampleRows& sum) {
  lower_gram<Lanes8>(samples, first, last, sum);
}

[[gnu::target("avx2")]] void lower_gram_avx2(const Eigen::Ref<const SampleRows>& samples, int first, int last,
                                              SampleRows& sum) {
  lower_gram<Lanes4>(samples, first, last, sum);
}

// The widest lanes this CPU has. Set before main; a call during another
// file's static initialisation sees kBaseline and takes the baseline path,
// which gives the same results.
SampleSumsPath widest_path() noexcept {
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f")) return SampleSumsPath::kAvx512;
  if (__builtin_cpu_supports("avx2")) return SampleSumsPath::kAvx2;
  return SampleSumsPath::kBaseline;
}
const SampleSumsPath kPath = widest_path();
#else
constexpr SampleSumsPath kPath = SampleSumsPath::kBaseline;
#endif
#pragma GCC diagnostic pop

void check_sum(const Eigen::Ref<const SampleRows>& samples, int first, int last, const SampleRows& sum) {
  eigen_assert(sum.rows() == samples.cols() && sum.cols() == samples.cols());
  eigen_assert(0 <= first && first <= last && last <= samples.cols());
  static_cast<void>(samples), static_cast<void>(first), static_cast<void>(last), static_cast<void>(sum);
}

}  // namespace

namespace detail {

SampleSumsPath widest_sample_sums_path() noexcept { return kPath; }

void add_lower_gram_on(SampleSumsPath path, const Eigen::Ref<const SampleRows>& samples, int first, int last,
                       SampleRows& sum) {
  check_sum(samples, first, last, sum);
  eigen_assert(path <= kPath);
  switch (path) {
#if defined(__x86_64__)
    case SampleSumsPath::kAvx512:
      return lower_gram_avx512(samples, first, last, sum);
    case SampleSumsPath::kAvx2:
      return lower_gram_avx2(samples, first, last, sum);
#endif
    default:
      return lower_gram<Lanes2>(samples, first, last, sum);
  }
}

}  // namespace detail

void add_lower_gram(const Eigen::Ref<const SampleRows>& samples, int first, int last, SampleRows& sum) {
  detail::add_lower_gram_on(kPath, samples, first, last, sum);
}

void add_transposed_product(const Eigen::Ref<const SampleRows>& samples, const Eigen::Ref<const Eigen::MatrixXd>& right,
                            Eigen::MatrixXd& sum) {
  eigen_assert(right.rows() == samples.rows() && sum.rows() == samples.cols() && sum.cols() == right.cols());
  const Eigen::Index width = samples.cols();
  for (Eigen::Index t = 0; t < samples.rows(); ++t) {
    const double* __restrict row = samples.data() + t * samples.outerStride();
    for (Eigen::Index d = 0; d < right.cols(); ++d) {
      double* __restrict column = sum.col(d).data();
      const double r = right(t, d);
      for (Eigen::Index i = 0; i < width; ++i) column[i] += row[i] * r;
    }
  }
}

}  // namespace clm::identification
