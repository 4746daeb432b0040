#include "commutation/network.hpp"

#include <cmath>

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
  double buffer[2][kMaxWidth];
  double* in = buffer[0];
  double* out = buffer[1];
  in[0] = input;
  Eigen::Index in_size = 1;
  const std::size_t hidden = layers.size() - 1;
  for (std::size_t i = 0; i < hidden; ++i) {
    const auto& layer = layers[i];
    const Eigen::Index rows = layer.weights.rows();
    for (Eigen::Index r = 0; r < rows; ++r) {
      double sum = layer.biases[r];
      for (Eigen::Index c = 0; c < in_size; ++c) sum += layer.weights(r, c) * in[c];
      out[r] = std::tanh(sum);
    }
    std::swap(in, out);
    in_size = rows;
  }
  const auto& last = layers.back();
  Eigen::Vector3d result;
  for (Eigen::Index r = 0; r < kOutputSize; ++r) {
    double sum = last.biases[r];
    for (Eigen::Index c = 0; c < in_size; ++c) sum += last.weights(r, c) * in[c];
    result[r] = sum;
  }
  return result;
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
