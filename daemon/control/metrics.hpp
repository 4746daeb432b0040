#pragma once
// Figures of merit of the paper's Table 2: the mean-square commutation error
// F − F* per direction [y, x, z], unfiltered and after the 50 Hz low-pass of
// docs/commutation.md §11, and the mean square of any signal (e.g. the tracking error).

#include <Eigen/Core>
#include <array>
#include <span>

namespace clm::control {

/// ZOH discretisation of 1/(s/(2π·f_c) + 1) (docs/commutation.md §11):
///   y[k] = a·y[k−1] + (1−a)·u[k−1],  a = exp(−2π·f_c·T_s).
/// The output lags the input by one sample; the state (y and the previous
/// input) starts at zero, so the step response is y[k] = 1 − a^k.
class CommutationErrorFilter {
 public:
  /// Throws std::invalid_argument unless cutoff_hz and period_s are positive and finite.
  CommutationErrorFilter(double cutoff_hz, double period_s);

  /// Takes u[k], returns y[k] (which depends on u[0..k−1] only).
  double update(double input) noexcept;
  /// Returns y and the previous input to zero.
  void reset() noexcept;

  /// a = exp(−2π·f_c·T_s) [-].
  double pole() const noexcept { return pole_; }

 private:
  double pole_;
  double output_ = 0.0;
  double previous_input_ = 0.0;
};

/// Mean-square commutation error per direction, ordered [y, x, z]
/// in [N², N², N²·m²].
struct DirectionMse {
  std::array<double, 3> filtered{};    ///< after CommutationErrorFilter
  std::array<double, 3> unfiltered{};  ///< of F − F* as recorded
};

/// MSE of e_k = measured_k − desired_k ([F_y, F_x, T_z] in [N, N, N·m]) per
/// direction over all N samples, unfiltered and filtered with
/// CommutationErrorFilter(cutoff_hz, period_s). The filter state starts at
/// zero and no sample is discarded: the filtered error needs about
/// 3/(2π·f_c) (≈ 10 ms at 50 Hz) to settle, which is negligible for a record
/// that starts at rest with a small error (as the Fig. 8 runs do); trim the
/// record beforehand if it starts with a large error.
/// Throws std::invalid_argument if the sizes differ, the record is empty, or
/// period/cutoff are not positive and finite.
DirectionMse commutation_error_mse(std::span<const Eigen::Vector3d> measured_wrench,
                                   std::span<const Eigen::Vector3d> desired_wrench, double period_s,
                                   double cutoff_hz = 50.0);

/// (1/N)·Σ x_k². Throws std::invalid_argument for an empty signal.
double mean_square(std::span<const double> signal);

}  // namespace clm::control
