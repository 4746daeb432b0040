#include "commutation/identification/physics_fit.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>

#include "commutation/elementary.hpp"

namespace clm::identification {

DirectionForce direction_shape(const CoilSetDataset& data, double direction_smoothing_m_per_s) {
  DirectionForce shape;
  if (direction_smoothing_m_per_s > 0.0 && data.velocity_m_per_s.size() == data.size()) {
    shape.smoothing_velocity_m_per_s = direction_smoothing_m_per_s;
  }
  return shape;
}

PhysicsFit fit_physics_only(const CoilSetDataset& data, double pole_pitch_m, double direction_smoothing_m_per_s) {
  check_dataset(data, "physics-only fit:");
  PhysicsFit fit;
  fit.direction = direction_shape(data, direction_smoothing_m_per_s);
  // Columns [c·i_a, c·i_b, s·i_a, s·i_b, 1, tanh(ẏ/v_c)]; the last only with a direction term.
  const int p = fit.direction.identified() ? 6 : 5;
  Eigen::Matrix<double, 6, 6> gram = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 3> rhs = Eigen::Matrix<double, 6, 3>::Zero();
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    const double theta = electrical_angle_rad(data.position_m[t], pole_pitch_m);
    const auto [s, c] = elementary::sin_cos(theta);
    const double ia = data.currents_A(0, t), ib = data.currents_A(1, t);
    const double d = fit.direction.identified() ? fit.direction.feature(data.velocity_m_per_s[t]) : 0.0;
    Eigen::Matrix<double, 6, 1> m;
    m << c * ia, c * ib, s * ia, s * ib, 1.0, d;
    gram.noalias() += m * m.transpose();
    rhs.noalias() += m * data.wrench.col(t).transpose();
  }
  const Eigen::MatrixXd used = gram.topLeftCorner(p, p);
  Eigen::LDLT<Eigen::MatrixXd> solver(used);
  if (solver.info() != Eigen::Success || solver.rcond() < 1e-12) {
    throw std::invalid_argument("physics-only fit is singular: the currents do not excite both columns of K");
  }
  const Eigen::MatrixXd solution = solver.solve(rhs.topRows(p));
  for (int q = 0; q < 3; ++q) {
    fit.a_N_per_A(q, 0) = solution(0, q);
    fit.a_N_per_A(q, 1) = solution(1, q);
    fit.b_N_per_A(q, 0) = solution(2, q);
    fit.b_N_per_A(q, 1) = solution(3, q);
    fit.constant[q] = solution(4, q);
    fit.direction.amplitude[q] = p == 6 ? solution(5, q) : 0.0;
  }
  return fit;
}

// θ*_phy,q of one direction in layout order [A_q0, A_q1, B_q0, B_q1].
Eigen::Vector4d physics_target(const CoilGain& a, const CoilGain& b, int q) {
  return {a(q, 0), a(q, 1), b(q, 0), b(q, 1)};
}

}  // namespace clm::identification
