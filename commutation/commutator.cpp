#include "commutation/commutator.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace clm {

double current_square_sum(const CurrentVector& currents_A) noexcept {
  double sum = 0.0;
  for (Eigen::Index l = 0; l + 1 < currents_A.size(); l += 2) {
    const double a = currents_A[l];
    const double b = currents_A[l + 1];
    sum += a * a + b * b + (a + b) * (a + b);
  }
  return sum;
}

ModelCommutator::ModelCommutator(const ElectromagneticModel& model, const DriveCommutation& drive,
                                 const ModelCommutatorOptions& options)
    : model_(&model), drive_(drive), options_(options) {
  model.validate();
  if (!(drive.motor_constant_N_per_A > 0.0)) {
    throw std::invalid_argument("drive motor constant must be positive, got " +
                                std::to_string(drive.motor_constant_N_per_A));
  }
  if (!(options.min_singular_value_ratio >= 0.0 && options.min_singular_value_ratio < 1.0)) {
    throw std::invalid_argument("min_singular_value_ratio must lie in [0, 1)");
  }
  if (FusedPgnnEvaluator::supports(model)) fused_.emplace(model);
}

void ModelCommutator::commutate(double position_m, const Wrench& desired, CommutationOutput& out) const noexcept {
  StackedGain gain;
  Wrench cogging;
  if (fused_) {
    fused_->evaluate(position_m, gain, cogging);
  } else {
    model_->evaluate(position_m, gain, cogging);
  }
  commutate_with_gain(gain, cogging, desired, position_m, model_->pole_pitch_m, drive_, options_, out);
}

void commutate_with_gain(const StackedGain& gain, const Wrench& cogging, const Wrench& desired,
                         double position_m, double pole_pitch_m, const DriveCommutation& drive,
                         const ModelCommutatorOptions& options, CommutationOutput& out) noexcept {
  const auto count = static_cast<int>(gain.cols() / 2);
  const Wrench demand = desired - cogging;  // eq. (37)

  // Weighted gain K̂·W⁻¹ with W = blockdiag([[2,1],[1,2]]) for true power
  // (docs/commutation.md §6), W = I for the paper's current norm.
  StackedGain weighted = gain;
  if (options.power_metric == PowerMetric::kTruePower) {
    for (int l = 0; l < count; ++l) {
      const Eigen::Vector3d a = gain.col(2 * l);
      const Eigen::Vector3d b = gain.col(2 * l + 1);
      weighted.col(2 * l) = (2.0 * a - b) / 3.0;
      weighted.col(2 * l + 1) = (2.0 * b - a) / 3.0;
    }
  }

  const double ratio_min = options.min_singular_value_ratio;
  out.coil_sets = count;
  out.currents_A.resize(2 * count);
  if (2 * count >= 3) {
    // Overactuated: i = W⁻¹K̂ᵀ(K̂W⁻¹K̂ᵀ + λ²I)⁻¹ r, λ = 0 unless ill-conditioned.
    // Block by block with fixed 3×2 sizes: cheaper than one dynamic product.
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    for (int l = 0; l < count; ++l) {
      const Eigen::Matrix<double, 3, 2> w = weighted.middleCols<2>(2 * l);
      const Eigen::Matrix<double, 3, 2> k = gain.middleCols<2>(2 * l);
      normal.noalias() += w * k.transpose();
    }
    normal = 0.5 * (normal + normal.transpose()).eval();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
    eigen.computeDirect(normal, Eigen::EigenvaluesOnly);
    const double largest = std::max(eigen.eigenvalues()(2), 0.0);
    const double smallest = std::max(eigen.eigenvalues()(0), 0.0);
    out.singular_value_ratio = largest > 0.0 ? std::sqrt(smallest / largest) : 0.0;
    out.damping_engaged = out.singular_value_ratio < ratio_min;
    if (out.damping_engaged) normal.diagonal().array() += ratio_min * ratio_min * largest;
    const Eigen::Vector3d multiplier = normal.llt().solve(demand);
    out.currents_A.noalias() = weighted.transpose() * multiplier;
  } else {
    // L = 1, underactuated: least-squares wrench, i = (K̂ᵀK̂ + λ²I)⁻¹K̂ᵀ r. The
    // solution is unique, so the power metric does not change it.
    const Eigen::Matrix<double, 3, 2> k = gain.leftCols<2>();
    Eigen::Matrix2d normal = k.transpose() * k;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen;
    eigen.computeDirect(normal, Eigen::EigenvaluesOnly);
    const double largest = std::max(eigen.eigenvalues()(1), 0.0);
    const double smallest = std::max(eigen.eigenvalues()(0), 0.0);
    out.singular_value_ratio = largest > 0.0 ? std::sqrt(smallest / largest) : 0.0;
    out.damping_engaged = out.singular_value_ratio < ratio_min;
    if (out.damping_engaged) normal.diagonal().array() += ratio_min * ratio_min * largest;
    out.currents_A = normal.llt().solve(k.transpose() * demand);
  }
  if (!out.currents_A.allFinite()) out.currents_A.setZero();  // zero gain: nothing to command

  out.model_wrench.noalias() = gain * out.currents_A;
  out.driving_gain_N_per_A = gain.row(0).transpose();
  out.model_wrench += cogging;
  out.current_square_sum_A2 = current_square_sum(out.currents_A);
  // Eq. (39); Γ uses the drive's angle, common to all coil sets (docs/commutation.md §5).
  const Eigen::Matrix2d gamma_inv = gamma_inverse(drive, position_m, pole_pitch_m);
  for (int l = 0; l < count; ++l) {
    out.setpoints[static_cast<std::size_t>(l)] =
        transform_inverse(gamma_inv * out.currents_A.segment<2>(2 * l), options.phase_convention);
  }
}

ClassicalCommutator::ClassicalCommutator(std::span<const ClassicalEstimate> estimates, double pole_pitch_m,
                                         const DriveCommutation& drive, PhaseConvention convention)
    : count_(static_cast<int>(estimates.size())), pole_pitch_m_(pole_pitch_m), drive_(drive), convention_(convention) {
  if (count_ < 1 || count_ > kMaxCoilSets) {
    throw std::invalid_argument("classical commutation: " + std::to_string(count_) + " coil sets, expected 1.." +
                                std::to_string(kMaxCoilSets));
  }
  for (int l = 0; l < count_; ++l) {
    const auto& estimate = estimates[static_cast<std::size_t>(l)];
    if (!(estimate.motor_constant_N_per_A > 0.0) || !std::isfinite(estimate.phase_offset_rad)) {
      throw std::invalid_argument("classical commutation: coil set " + std::to_string(l + 1) +
                                  " needs a positive motor constant and a finite phase offset");
    }
    estimates_[static_cast<std::size_t>(l)] = estimate;
  }
}

void ClassicalCommutator::commutate(double position_m, const Wrench& desired, CommutationOutput& out) const noexcept {
  const std::span<const ClassicalEstimate> estimates(estimates_.data(), static_cast<std::size_t>(count_));
  out.coil_sets = count_;
  classical_currents(estimates, pole_pitch_m_, position_m, desired.x(), out.currents_A, &out.driving_gain_N_per_A);
  classical_setpoints(estimates, drive_, desired.x(), convention_,
                      std::span<DriveSetpoint>(out.setpoints.data(), static_cast<std::size_t>(count_)));
  // The classical law's own model: each coil set produces its share along y only.
  out.model_wrench = Wrench(desired.x(), 0.0, 0.0);
  out.current_square_sum_A2 = current_square_sum(out.currents_A);
  out.singular_value_ratio = 1.0;
  out.damping_engaged = false;
}

}  // namespace clm
