#include "commutation/identification/physics_fit.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>

namespace clm::identification {

void fit_physics_only(const CoilSetDataset& data, double pole_pitch_m, CoilGain& a, CoilGain& b) {
  check_dataset(data, "physics-only fit:");
  Eigen::Matrix4d gram = Eigen::Matrix4d::Zero();
  Eigen::Matrix<double, 4, 3> rhs = Eigen::Matrix<double, 4, 3>::Zero();
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    const double theta = electrical_angle_rad(data.position_m[t], pole_pitch_m);
    const double c = std::cos(theta), s = std::sin(theta);
    const double ia = data.currents_A(0, t), ib = data.currents_A(1, t);
    const Eigen::Vector4d m(c * ia, c * ib, s * ia, s * ib);
    gram.noalias() += m * m.transpose();
    rhs.noalias() += m * data.wrench.col(t).transpose();
  }
  Eigen::LDLT<Eigen::Matrix4d> solver(gram);
  if (solver.info() != Eigen::Success || solver.rcond() < 1e-12) {
    throw std::invalid_argument("physics-only fit is singular: the currents do not excite both columns of K");
  }
  const Eigen::Matrix<double, 4, 3> solution = solver.solve(rhs);
  for (int q = 0; q < 3; ++q) {
    a(q, 0) = solution(0, q);
    a(q, 1) = solution(1, q);
    b(q, 0) = solution(2, q);
    b(q, 1) = solution(3, q);
  }
}

// θ*_phy,q of one direction in layout order [A_q0, A_q1, B_q0, B_q1].
Eigen::Vector4d physics_target(const CoilGain& a, const CoilGain& b, int q) {
  return {a(q, 0), a(q, 1), b(q, 0), b(q, 1)};
}

}  // namespace clm::identification
