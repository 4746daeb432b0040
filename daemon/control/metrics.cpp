#include "daemon/control/metrics.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "commutation/elementary.hpp"
#include "daemon/control/checks.hpp"

namespace clm::control {

CommutationErrorFilter::CommutationErrorFilter(double cutoff_hz, double period_s) {
  detail::require_positive_finite("CommutationErrorFilter", "cutoff_hz", cutoff_hz);
  detail::require_positive_finite("CommutationErrorFilter", "period_s", period_s);
  pole_ = elementary::exp(-2.0 * std::numbers::pi * cutoff_hz * period_s);
}

double CommutationErrorFilter::update(double input) noexcept {
  output_ = pole_ * output_ + (1.0 - pole_) * previous_input_;
  previous_input_ = input;
  return output_;
}

void CommutationErrorFilter::reset() noexcept {
  output_ = 0.0;
  previous_input_ = 0.0;
}

DirectionMse commutation_error_mse(std::span<const Eigen::Vector3d> measured_wrench,
                                   std::span<const Eigen::Vector3d> desired_wrench, double period_s,
                                   double cutoff_hz) {
  constexpr const char* kContext = "commutation_error_mse";
  if (measured_wrench.size() != desired_wrench.size()) {
    throw std::invalid_argument(std::string(kContext) + ": measured_wrench has " +
                                std::to_string(measured_wrench.size()) + " samples but desired_wrench has " +
                                std::to_string(desired_wrench.size()));
  }
  if (measured_wrench.empty()) throw std::invalid_argument(std::string(kContext) + ": no samples");
  // The constructor checks period_s and cutoff_hz.
  std::array<CommutationErrorFilter, 3> filters{CommutationErrorFilter(cutoff_hz, period_s),
                                                CommutationErrorFilter(cutoff_hz, period_s),
                                                CommutationErrorFilter(cutoff_hz, period_s)};
  DirectionMse mse;
  for (std::size_t k = 0; k < measured_wrench.size(); ++k) {
    const Eigen::Vector3d error = measured_wrench[k] - desired_wrench[k];
    for (int d = 0; d < 3; ++d) {
      const auto i = static_cast<std::size_t>(d);
      const double filtered = filters[i].update(error(d));
      mse.unfiltered[i] += error(d) * error(d);
      mse.filtered[i] += filtered * filtered;
    }
  }
  const double count = static_cast<double>(measured_wrench.size());
  for (std::size_t i = 0; i < 3; ++i) {
    mse.unfiltered[i] /= count;
    mse.filtered[i] /= count;
  }
  return mse;
}

double mean_square(std::span<const double> signal) {
  if (signal.empty()) throw std::invalid_argument("mean_square: empty signal");
  double sum = 0.0;
  for (const double x : signal) sum += x * x;
  return sum / static_cast<double>(signal.size());
}

}  // namespace clm::control
