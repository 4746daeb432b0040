// The identification's sums over samples (commutation/identification/
// sample_sums.hpp) against their definition: each entry one multiply and one
// add per sample, in sample order. Bit for bit on every path the CPU has
// (SSE2, AVX2, AVX-512F), however the samples are split into calls; and the
// definition against long double.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <random>
#include <utility>
#include <vector>

#include "commutation/identification/sample_sums.hpp"

// The definition below must not be fused either.
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

using namespace clm;
using identification::SampleRows;

namespace {

SampleRows random_samples(Eigen::Index rows, Eigen::Index columns, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> value(-3.0, 3.0);
  SampleRows samples(rows, columns);
  for (Eigen::Index t = 0; t < rows; ++t) {
    for (Eigen::Index i = 0; i < columns; ++i) samples(t, i) = value(rng);
  }
  if (rows > 2 && columns > 2) samples(1, 2) = -0.0;  // signed zeros go through as the definition has them
  return samples;
}

// Entry (i, j) of the lower triangle as defined: start, then + s_ti·s_tj in t order.
double defined_entry(const SampleRows& samples, Eigen::Index i, Eigen::Index j, double start) {
  double sum = start;
  for (Eigen::Index t = 0; t < samples.rows(); ++t) sum += samples(t, i) * samples(t, j);
  return sum;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST_CASE("add_lower_gram gives each entry's sum in sample order, the same bits on every path the CPU has",
          "[identification][sample_sums]") {
  using identification::detail::SampleSumsPath;
  const char* const names[] = {"baseline (SSE2)", "AVX2", "AVX-512"};
  std::vector<SampleSumsPath> paths;
  for (const auto path : {SampleSumsPath::kBaseline, SampleSumsPath::kAvx2, SampleSumsPath::kAvx512}) {
    if (path <= identification::detail::widest_sample_sums_path()) paths.push_back(path);
  }
  INFO("this CPU's widest path: " << names[static_cast<int>(paths.back())]);
  // Widths around the tiles (4 rows × 2 vectors, 1 row × 1 vector, then
  // entry by entry), sample counts around the passes of 64 rows.
  for (const int width : {1, 3, 4, 5, 8, 13, 16, 17, 31, 40, 97}) {
    for (const Eigen::Index rows : {1, 7, 64, 65, 200}) {
      const SampleRows samples = random_samples(rows, width, static_cast<std::uint64_t>(width * 1000 + rows));
      for (const auto& [first, last] : {std::pair{0, width}, std::pair{width / 3, width}, std::pair{0, (width + 1) / 2}}) {
        const SampleRows start = random_samples(width, width, 7);  // sums accumulate onto what is there
        for (const auto path : paths) {
          INFO(names[static_cast<int>(path)] << " path, width " << width << ", " << rows << " samples, rows " << first
                                             << ".." << last);
          SampleRows whole = start, split = start;
          identification::detail::add_lower_gram_on(path, samples, first, last, whole);
          const Eigen::Index half = rows / 2;
          identification::detail::add_lower_gram_on(path, samples.topRows(half), first, last, split);
          identification::detail::add_lower_gram_on(path, samples.bottomRows(rows - half), first, last, split);
          for (int i = first; i < last; ++i) {
            for (int j = 0; j <= i; ++j) {
              const double defined = defined_entry(samples, i, j, start(i, j));
              INFO("entry (" << i << ", " << j << ")");
              CHECK(same_bits(whole(i, j), defined));
              CHECK(same_bits(split(i, j), defined));
            }
          }
          // Rows outside [first, last) are untouched.
          for (int i = 0; i < width; ++i) {
            if (i >= first && i < last) continue;
            for (int j = 0; j < width; ++j) CHECK(same_bits(whole(i, j), start(i, j)));
          }
        }
        // The definition itself against long double.
        for (int i = first; i < last; ++i) {
          for (int j = 0; j <= i; ++j) {
            long double exact = start(i, j);
            for (Eigen::Index t = 0; t < rows; ++t) {
              exact += static_cast<long double>(samples(t, i)) * static_cast<long double>(samples(t, j));
            }
            INFO("entry (" << i << ", " << j << ") against long double");
            CHECK(std::fabs(static_cast<long double>(defined_entry(samples, i, j, start(i, j))) - exact) <=
                  1e-13L * (1.0L + std::fabs(exact)) * static_cast<long double>(rows));
          }
        }
      }
    }
  }
}

TEST_CASE("add_transposed_product gives each entry's sum in sample order", "[identification][sample_sums]") {
  const SampleRows samples = random_samples(131, 23, 3);
  const SampleRows right_rows = random_samples(131, 3, 4);
  const Eigen::MatrixXd right = right_rows;
  Eigen::MatrixXd sum = Eigen::MatrixXd::Constant(23, 3, 0.25);
  identification::add_transposed_product(samples, right, sum);
  for (int i = 0; i < 23; ++i) {
    for (int d = 0; d < 3; ++d) {
      double defined = 0.25;
      for (Eigen::Index t = 0; t < 131; ++t) defined += samples(t, i) * right(t, d);
      INFO("entry (" << i << ", " << d << ")");
      CHECK(same_bits(sum(i, d), defined));
    }
  }
}
