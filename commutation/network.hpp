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
