#include "commutation/identification/nuisance.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "commutation/elementary.hpp"
#include "commutation/types.hpp"

namespace clm::identification {

Eigen::VectorXd differentiate(const Eigen::VectorXd& time_s, const Eigen::VectorXd& values) {
  const Eigen::Index n = time_s.size();
  if (values.size() != n) throw std::invalid_argument("differentiate: times and values have different lengths");
  if (!time_s.allFinite() || !values.allFinite()) throw std::invalid_argument("differentiate: non-finite input");
  Eigen::VectorXd derivative = Eigen::VectorXd::Zero(n);
  if (n < 2) return derivative;
  std::vector<double> steps;
  steps.reserve(static_cast<std::size_t>(n - 1));
  for (Eigen::Index k = 0; k + 1 < n; ++k) {
    const double dt = time_s[k + 1] - time_s[k];
    if (dt > 0.0) steps.push_back(dt);
  }
  if (steps.empty()) return derivative;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  const double limit = 1.5 * steps[steps.size() / 2];
  const auto joined = [&](Eigen::Index k) {  // samples k and k + 1 belong to one stretch
    const double dt = time_s[k + 1] - time_s[k];
    return dt > 0.0 && dt <= limit;
  };
  for (Eigen::Index k = 0; k < n; ++k) {
    const bool back = k > 0 && joined(k - 1);
    const bool ahead = k + 1 < n && joined(k);
    const Eigen::Index first = back ? k - 1 : k;
    const Eigen::Index last = ahead ? k + 1 : k;
    if (first != last) derivative[k] = (values[last] - values[first]) / (time_s[last] - time_s[first]);
  }
  return derivative;
}

DrivingOffsetFit fit_driving_sensor_offset(const std::vector<MotionRecord>& records) {
  std::vector<Eigen::VectorXd> velocity, acceleration;
  Eigen::Index samples = 0;
  for (const auto& record : records) {
    if (record.position_m.size() != record.time_s.size() || record.force_N.size() != record.time_s.size()) {
      throw std::invalid_argument("sensor offset fit: times, positions and forces have different lengths");
    }
    velocity.push_back(differentiate(record.time_s, record.position_m));
    acceleration.push_back(differentiate(record.time_s, velocity.back()));
    samples += record.time_s.size();
  }
  if (samples < 10) throw std::invalid_argument("sensor offset fit: fewer than 10 samples");

  DrivingOffsetFit best;
  double best_sum = std::numeric_limits<double>::infinity();
  for (const double smoothing : kDirectionSmoothingGrid_m_per_s) {
    // Regressors [ÿ, ẏ, tanh(ẏ/v_s), 1], scaled to unit RMS for the condition.
    Eigen::Matrix4d gram = Eigen::Matrix4d::Zero();
    Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
    double force_square = 0.0;
    for (std::size_t r = 0; r < records.size(); ++r) {
      for (Eigen::Index t = 0; t < records[r].time_s.size(); ++t) {
        const double v = velocity[r][t];
        const Eigen::Vector4d m(acceleration[r][t], v, elementary::tanh(v / smoothing), 1.0);
        gram.noalias() += m * m.transpose();
        rhs.noalias() += m * records[r].force_N[t];
        force_square += records[r].force_N[t] * records[r].force_N[t];
      }
    }
    const Eigen::Vector4d scale = gram.diagonal().cwiseSqrt().cwiseMax(1e-300).cwiseInverse();
    const Eigen::Matrix4d scaled = scale.asDiagonal() * gram * scale.asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eigen(scaled);
    const double smallest = std::max(eigen.eigenvalues().minCoeff(), 0.0);
    const double condition = smallest > 0.0 ? std::sqrt(eigen.eigenvalues().maxCoeff() / smallest)
                                            : std::numeric_limits<double>::infinity();
    if (!(condition < 1e6)) continue;
    const Eigen::Vector4d solution = scale.asDiagonal() * scaled.ldlt().solve(scale.asDiagonal() * rhs);
    // Σ(F − mᵀx)² = ΣF² − 2xᵀrhs + xᵀGx.
    const double sum = std::max(0.0, force_square - 2.0 * solution.dot(rhs) + solution.dot(gram * solution));
    if (sum < best_sum) {
      best_sum = sum;
      best = {solution[3], solution[0], solution[1], solution[2], smoothing,
              std::sqrt(sum / static_cast<double>(samples)), condition, samples};
    }
  }
  if (!(best_sum < std::numeric_limits<double>::infinity())) {
    throw std::invalid_argument("sensor offset fit: the motion does not excite mass, friction and offset apart "
                                "(the experiments need moves in both directions and standstill)");
  }
  return best;
}

double direction_force_inflation(const CoilSetDataset& data, double pole_pitch_m, double direction_smoothing_m_per_s) {
  if (data.velocity_m_per_s.size() != data.size() || data.size() < 10 || !(direction_smoothing_m_per_s > 0.0)) {
    return std::numeric_limits<double>::infinity();
  }
  Eigen::Matrix<double, 5, 5> gram = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 1> cross = Eigen::Matrix<double, 5, 1>::Zero();
  double sum = 0.0, square = 0.0;
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    const double theta = kTwoPi * data.position_m[t] / pole_pitch_m;
    const auto [s, c] = elementary::sin_cos(theta);
    const double ia = data.currents_A(0, t), ib = data.currents_A(1, t);
    Eigen::Matrix<double, 5, 1> m;
    m << c * ia, c * ib, s * ia, s * ib, 1.0;
    const double d = elementary::tanh(data.velocity_m_per_s[t] / direction_smoothing_m_per_s);
    gram.noalias() += m * m.transpose();
    cross += m * d;
    sum += d;
    square += d * d;
  }
  const double n = static_cast<double>(data.size());
  const double total = square - sum * sum / n;  // Σ(d − d̄)²
  if (!(total > 0.0)) return std::numeric_limits<double>::infinity();
  const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> solver(gram);
  const double residual = std::max(0.0, square - cross.dot(solver.solve(cross)));
  return residual > 0.0 ? total / residual : std::numeric_limits<double>::infinity();
}

}  // namespace clm::identification
