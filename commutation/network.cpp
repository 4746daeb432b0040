#include "commutation/network.hpp"

#include <cmath>

#include "commutation/elementary.hpp"

namespace clm {

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
    elementary::tanh_array(sum, activation, static_cast<int>(rows));
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
