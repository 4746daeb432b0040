#pragma once
// The feed-forward networks of the PGNN, eq. (25): scalar (normalised position)
// input, tanh hidden layers, linear output of three entries (a column of K̂ or
// the cogging wrench).

#include <Eigen/Core>
#include <string>
#include <vector>

namespace clm {

struct DenseLayer {
  Eigen::MatrixXd weights;  ///< n_i × n_{i−1}
  Eigen::VectorXd biases;   ///< n_i
};

/// tanh of `count` values: out[k] = tanh(in[k]) (`out` may be `in`), in
/// double precision with no call into libm, several lanes at a time (SSE2,
/// or AVX2 where the CPU has it, chosen at run time; both give bit-identical
/// results). Relative error within a few ulp of std::tanh (≤ 1e-13 is tested
/// over a dense grid, tiny and saturating arguments included); ±0 and the
/// sign are kept, ±∞ gives ±1, NaN stays NaN. No allocation, no exception.
/// The cycle's networks use it.
void tanh_array(const double* in, double* out, int count) noexcept;

namespace detail {
/// tanh_array on the baseline path (2 lanes), whatever the CPU; for tests.
void tanh_array_baseline(const double* in, double* out, int count) noexcept;
/// Whether tanh_array takes the AVX2 path on this CPU.
bool tanh_array_uses_avx2() noexcept;
}  // namespace detail

class Network {
 public:
  /// Widest hidden layer the cycle's fixed storage holds.
  static constexpr int kMaxWidth = 64;
  static constexpr int kOutputSize = 3;

  /// Hidden layers (tanh) followed by one linear output layer. No layers at
  /// all is the zero function (the physics-only model).
  std::vector<DenseLayer> layers;

  /// Network with the given hidden sizes and all parameters zero.
  static Network zeros(const std::vector<int>& hidden_sizes);

  bool empty() const { return layers.empty(); }
  std::vector<int> hidden_sizes() const;
  int parameter_count() const;

  /// Output at a (normalised) input. No allocation, no exception.
  Eigen::Vector3d evaluate(double input) const noexcept;

  /// Empty when the shapes are consistent (input 1, output 3, hidden widths
  /// 1..kMaxWidth) and every parameter is finite; otherwise what is wrong.
  std::string shape_error() const;
};

}  // namespace clm
