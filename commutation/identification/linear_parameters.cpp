#include "commutation/identification/linear_parameters.hpp"

#include <Eigen/Dense>
#include <algorithm>

#include "commutation/identification/physics_fit.hpp"
#include "commutation/identification/sample_sums.hpp"

namespace clm::identification {

PgnnFeatures features_of(const CoilSetDataset& data, double pole_pitch_m, const PositionNormalisation& normalisation,
                         const DirectionForce& direction) {
  PgnnFeatures f;
  f.cos_theta.resize(data.size());
  f.sin_theta.resize(data.size());
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    const auto [s, c] = elementary::sin_cos(data.position_m[t] * (kTwoPi / pole_pitch_m));
    f.cos_theta[t] = c;
    f.sin_theta[t] = s;
  }
  f.input = (data.position_m.array() - normalisation.offset_m) / normalisation.scale_m;
  f.direction = Eigen::ArrayXd::Zero(data.size());
  if (direction.identified() && data.velocity_m_per_s.size() == data.size()) {
    for (Eigen::Index t = 0; t < data.size(); ++t) f.direction[t] = direction.feature(data.velocity_m_per_s[t]);
  }
  return f;
}

void linear_normal_equations(const CoilSetDataset& data, const PgnnFeatures& f, const PgnnLayout& layout,
                             const double* nonlinear, Eigen::MatrixXd& gram, Eigen::MatrixXd& rhs) {
  // Rows [M F] of a chunk of samples at a time; their Gram matrix holds MᵀM
  // and FᵀM.
  constexpr Eigen::Index kChunk = 256;
  const int p = layout.linear_size();
  SampleRows chunk(std::min(kChunk, data.size()), p + 3);
  SampleRows sums = SampleRows::Zero(p + 3, p + 3);
  double ha[Network::kMaxWidth], hb[Network::kMaxWidth], hc[Network::kMaxWidth];
  for (Eigen::Index begin = 0; begin < data.size(); begin += kChunk) {
    const Eigen::Index rows = std::min(kChunk, data.size() - begin);
    for (Eigen::Index k = 0; k < rows; ++k) {
      const Eigen::Index t = begin + k;
      double* row = chunk.row(k).data();
      regressor(layout, nonlinear, f.cos_theta[t], f.sin_theta[t], f.input[t], f.direction[t], data.currents_A(0, t),
                data.currents_A(1, t), row, ha, hb, hc);
      for (int d = 0; d < 3; ++d) row[p + d] = data.wrench(d, t);
    }
    add_lower_gram(chunk.topRows(rows), 0, p + 3, sums);
  }
  const double inv_n = 1.0 / static_cast<double>(data.size());
  gram = sums.topLeftCorner(p, p).selfadjointView<Eigen::Lower>();
  gram *= inv_n;
  rhs = sums.block(p, 0, 3, p).transpose() * inv_n;
}

RegressorQuality linear_regressor_quality(const CoilSetDataset& data, const PgnnFeatures& f, const PgnnLayout& layout,
                                          const double* nonlinear, const DirectionForce& direction) {
  Eigen::MatrixXd gram, rhs;
  linear_normal_equations(data, f, layout, nonlinear, gram, rhs);
  const int columns = direction.identified() ? layout.linear_size() : layout.direction_offset();
  std::vector<ColumnGroup> groups;
  for (int k = 0; k < columns; ++k) groups.push_back({k, 1});
  return regressor_quality(gram.topLeftCorner(columns, columns), groups);
}

void ridge_linear(const CoilSetDataset& data, const PgnnFeatures& f, const PgnnLayout& layout, const double* nonlinear,
                  const CoilGain& physics_a, const CoilGain& physics_b, double regularisation,
                  Eigen::Matrix<double, Eigen::Dynamic, 3>& linear) {
  const int p = layout.linear_size();
  Eigen::MatrixXd gram, rhs;
  linear_normal_equations(data, f, layout, nonlinear, gram, rhs);
  const double lambda2 = regularisation * regularisation;
  for (int k = 0; k < 4; ++k) gram(k, k) += lambda2;
  for (int q = 0; q < 3; ++q) rhs.block<4, 1>(0, q) += lambda2 * physics_target(physics_a, physics_b, q);
  // A tiny ridge on the output layers keeps the solve defined when a neuron is
  // saturated over the whole stroke (a constant column duplicates the bias),
  // and sets C_q to zero when the data carry no velocity.
  for (int k = 4; k < p; ++k) gram(k, k) += 1e-10 * (1.0 + gram(k, k));
  linear = gram.ldlt().solve(rhs);
}

void unpack_parameters(const PgnnLayout& layout, const double* nonlinear,
                       const Eigen::Matrix<double, Eigen::Dynamic, 3>& linear, CoilSetModel& coil_set,
                       DirectionForce& direction) {
  const int na = layout.column_hidden;
  const int nc = layout.cogging_hidden;
  coil_set.column_a = Network::zeros({na});
  coil_set.column_b = Network::zeros({na});
  coil_set.cogging = Network::zeros({nc});
  coil_set.gain_harmonics_N_per_A.resize(3, layout.gain_harmonic_count());
  coil_set.cogging_harmonics_N.resize(3, layout.cogging_harmonic_count());
  for (int j = 0; j < na; ++j) {
    coil_set.column_a.layers[0].weights(j, 0) = nonlinear[j];
    coil_set.column_a.layers[0].biases[j] = nonlinear[na + j];
    coil_set.column_b.layers[0].weights(j, 0) = nonlinear[2 * na + j];
    coil_set.column_b.layers[0].biases[j] = nonlinear[3 * na + j];
  }
  for (int j = 0; j < nc; ++j) {
    coil_set.cogging.layers[0].weights(j, 0) = nonlinear[4 * na + j];
    coil_set.cogging.layers[0].biases[j] = nonlinear[4 * na + nc + j];
  }
  for (int q = 0; q < 3; ++q) {
    coil_set.a_N_per_A(q, 0) = linear(0, q);
    coil_set.a_N_per_A(q, 1) = linear(1, q);
    coil_set.b_N_per_A(q, 0) = linear(2, q);
    coil_set.b_N_per_A(q, 1) = linear(3, q);
    for (int j = 0; j < na; ++j) {
      coil_set.column_a.layers[1].weights(q, j) = linear(layout.column_a_offset() + j, q);
      coil_set.column_b.layers[1].weights(q, j) = linear(layout.column_b_offset() + j, q);
    }
    coil_set.column_a.layers[1].biases[q] = linear(layout.column_a_offset() + na, q);
    coil_set.column_b.layers[1].biases[q] = linear(layout.column_b_offset() + na, q);
    for (int j = 0; j < nc; ++j) coil_set.cogging.layers[1].weights(q, j) = linear(layout.cogging_offset() + j, q);
    coil_set.cogging.layers[1].biases[q] = linear(layout.cogging_offset() + nc, q);
    for (int k = 0; k < layout.gain_harmonic_count(); ++k) {
      coil_set.gain_harmonics_N_per_A(q, k) = linear(layout.gain_harmonics_offset() + k, q);
    }
    for (int k = 0; k < layout.cogging_harmonic_count(); ++k) {
      coil_set.cogging_harmonics_N(q, k) = linear(layout.cogging_harmonics_offset() + k, q);
    }
    direction.amplitude[q] = direction.identified() ? linear(layout.direction_offset(), q) : 0.0;
  }
}

void pack_parameters(const PgnnLayout& layout, const CoilSetModel& coil_set, const DirectionForce& direction,
                     std::vector<double>& nonlinear, Eigen::Matrix<double, Eigen::Dynamic, 3>& linear) {
  const int na = layout.column_hidden;
  const int nc = layout.cogging_hidden;
  nonlinear.assign(static_cast<std::size_t>(layout.nonlinear_size()), 0.0);
  for (int j = 0; j < na; ++j) {
    nonlinear[static_cast<std::size_t>(j)] = coil_set.column_a.layers[0].weights(j, 0);
    nonlinear[static_cast<std::size_t>(na + j)] = coil_set.column_a.layers[0].biases[j];
    nonlinear[static_cast<std::size_t>(2 * na + j)] = coil_set.column_b.layers[0].weights(j, 0);
    nonlinear[static_cast<std::size_t>(3 * na + j)] = coil_set.column_b.layers[0].biases[j];
  }
  for (int j = 0; j < nc; ++j) {
    nonlinear[static_cast<std::size_t>(4 * na + j)] = coil_set.cogging.layers[0].weights(j, 0);
    nonlinear[static_cast<std::size_t>(4 * na + nc + j)] = coil_set.cogging.layers[0].biases[j];
  }
  linear.resize(layout.linear_size(), 3);
  for (int q = 0; q < 3; ++q) {
    linear(0, q) = coil_set.a_N_per_A(q, 0);
    linear(1, q) = coil_set.a_N_per_A(q, 1);
    linear(2, q) = coil_set.b_N_per_A(q, 0);
    linear(3, q) = coil_set.b_N_per_A(q, 1);
    for (int j = 0; j < na; ++j) {
      linear(layout.column_a_offset() + j, q) = coil_set.column_a.layers[1].weights(q, j);
      linear(layout.column_b_offset() + j, q) = coil_set.column_b.layers[1].weights(q, j);
    }
    linear(layout.column_a_offset() + na, q) = coil_set.column_a.layers[1].biases[q];
    linear(layout.column_b_offset() + na, q) = coil_set.column_b.layers[1].biases[q];
    for (int j = 0; j < nc; ++j) linear(layout.cogging_offset() + j, q) = coil_set.cogging.layers[1].weights(q, j);
    linear(layout.cogging_offset() + nc, q) = coil_set.cogging.layers[1].biases[q];
    for (int k = 0; k < layout.gain_harmonic_count(); ++k) {
      linear(layout.gain_harmonics_offset() + k, q) = coil_set.gain_harmonics_N_per_A(q, k);
    }
    for (int k = 0; k < layout.cogging_harmonic_count(); ++k) {
      linear(layout.cogging_harmonics_offset() + k, q) = coil_set.cogging_harmonics_N(q, k);
    }
    linear(layout.direction_offset(), q) = direction.amplitude[q];
  }
}

PgnnLayout PgnnLayout::of(const CoilSetModel& coil_set, const HarmonicOrders& harmonics) {
  return {static_cast<int>(coil_set.column_a.layers[0].biases.size()),
          static_cast<int>(coil_set.cogging.layers[0].biases.size()), harmonics};
}

PositionNormalisation normalisation_for(const Eigen::VectorXd& position_m) {
  const double low = position_m.minCoeff();
  const double high = position_m.maxCoeff();
  const double half = 0.5 * (high - low);
  return {0.5 * (high + low), half > 0.0 ? half : 1.0};
}

void solve_linear_parameters(const CoilSetDataset& data, double pole_pitch_m,
                             const PositionNormalisation& normalisation, const HarmonicOrders& harmonics,
                             const CoilGain& physics_a, const CoilGain& physics_b, double regularisation,
                             CoilSetModel& coil_set, DirectionForce& direction) {
  const PgnnLayout layout = PgnnLayout::of(coil_set, harmonics);
  std::vector<double> nonlinear;
  Eigen::Matrix<double, Eigen::Dynamic, 3> linear;
  pack_parameters(layout, coil_set, direction, nonlinear, linear);
  const PgnnFeatures f = features_of(data, pole_pitch_m, normalisation, direction);
  ridge_linear(data, f, layout, nonlinear.data(), physics_a, physics_b, regularisation, linear);
  unpack_parameters(layout, nonlinear.data(), linear, coil_set, direction);
}

}  // namespace clm::identification
