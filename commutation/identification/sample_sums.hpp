#pragma once
// Sums over samples for the identification's normal matrices (eq. 31, and
// JᵀJ, Jᵀr of Levenberg–Marquardt by variable projection), with one order of
// operations on every CPU: each entry is one multiply and one add per sample,
// in sample order, never fused. The work is vectorised across entries, never
// within one, so the AVX-512 and AVX2 paths (chosen at run time) and the
// baseline path give the same bits, and so does any split of the samples into calls or passes
// (docs/commutation.md, "Reproducibility"). No I/O.

#include <Eigen/Core>

namespace clm::identification {

/// Samples as rows: row t holds sample t's values, each row contiguous.
using SampleRows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// sum(i, j) += Σ_t samples(t, i)·samples(t, j) for first ≤ i < last and
/// j ≤ i: rows [first, last) of the lower triangle of SᵀS. `sum` is
/// samples.cols() square. Entries above the diagonal in those rows may be
/// written too and hold nothing of use; read the lower triangle.
void add_lower_gram(const Eigen::Ref<const SampleRows>& samples, int first, int last, SampleRows& sum);

/// sum(i, d) += Σ_t samples(t, i)·right(t, d): Sᵀ·R, `sum` samples.cols() ×
/// right.cols().
void add_transposed_product(const Eigen::Ref<const SampleRows>& samples,
                            const Eigen::Ref<const Eigen::MatrixXd>& right, Eigen::MatrixXd& sum);

namespace detail {
/// The lanes of add_lower_gram: 2 (SSE2, the x86-64 baseline), 4 (AVX2) or
/// 8 (AVX-512F).
enum class SampleSumsPath { kBaseline, kAvx2, kAvx512 };
/// The widest path this CPU has; add_lower_gram takes it.
SampleSumsPath widest_sample_sums_path() noexcept;
/// add_lower_gram on `path`, at most the widest; for tests.
void add_lower_gram_on(SampleSumsPath path, const Eigen::Ref<const SampleRows>& samples, int first, int last,
                       SampleRows& sum);
}  // namespace detail

}  // namespace clm::identification
