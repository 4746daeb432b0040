#include "daemon/control/tracking_split.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "commutation/bspline.hpp"
#include "commutation/elementary.hpp"
#include "commutation/types.hpp"

namespace clm::control {

TrackingSplit split_tracking_error(std::span<const double> position_m, std::span<const double> force_demand_N,
                                   std::span<const double> tracking_error_m, double pole_pitch_m, const PidGains& gains, double mass_kg, double period_s,
                                   int harmonics) {
  const auto n = static_cast<Eigen::Index>(position_m.size());
  if (position_m.size() != tracking_error_m.size() || position_m.size() != force_demand_N.size()) {
    throw std::invalid_argument("split_tracking_error: " + std::to_string(position_m.size()) + " positions, " +
                                std::to_string(force_demand_N.size()) + " force demands and " +
                                std::to_string(tracking_error_m.size()) + " tracking errors");
  }
  if (!(pole_pitch_m > 0.0) || !(mass_kg > 0.0) || !(period_s > 0.0) || !(harmonics > 0)) {
    throw std::invalid_argument("split_tracking_error: pole pitch, mass, period and harmonics must be positive");
  }
  double low_m = 0.0, high_m = 0.0;
  for (std::size_t k = 0; k < position_m.size(); ++k) {
    const double y = position_m[k];
    if (!std::isfinite(y) || !std::isfinite(force_demand_N[k])) {
      throw std::invalid_argument("split_tracking_error: sample " + std::to_string(k) + " not finite");
    }
    low_m = k == 0 ? y : std::min(low_m, y);
    high_m = k == 0 ? y : std::max(high_m, y);
  }
  UniformCubicBasis spline;
  spline.start_m = low_m;
  spline.end_m = std::max(high_m, low_m + 1e-9);
  spline.intervals =
      std::max(1, static_cast<int>(std::ceil((spline.end_m - spline.start_m) / (kTrackingSplitKnotPitches * pole_pitch_m))));
  const int shapes = 2 * harmonics + spline.size();
  const int columns = 2 * shapes;  // each shape alone, and times F*
  if (n < 4 * columns) {
    throw std::invalid_argument("split_tracking_error: " + std::to_string(n) + " samples for " +
                                std::to_string(columns) + " regressors (at least 4 per regressor)");
  }
  // Each force shape at the motor through the loop: the PID closed around
  // the mass, the force held over each period (exact for a constant force:
  // x += vT + aT²/2, v += aT). The regressor is the tracking error it
  // causes, −x.
  Eigen::MatrixXd regressors(n, columns);
  const double angle_per_m = kTwoPi / pole_pitch_m;
  const auto shape = [&](int column, double y) {
    column %= shapes;
    if (column < 2 * harmonics) {
      const double angle = angle_per_m * (column / 2 + 1) * y;
      return column % 2 == 0 ? elementary::cos(angle) : elementary::sin(angle);
    }
    const UniformCubicBasis::Span span = spline.evaluate(y);
    const int j = column - 2 * harmonics - span.first;
    return j >= 0 && j < 4 ? span.value[static_cast<std::size_t>(j)] : 0.0;
  };
  for (int column = 0; column < columns; ++column) {
    PidController pid(gains, period_s);
    double x = 0.0, v = 0.0;
    for (Eigen::Index k = 0; k < n; ++k) {
      const double error = -x;
      regressors(k, column) = error;
      const auto at = static_cast<std::size_t>(k);
      const double force = shape(column, position_m[at]) * (column < shapes ? 1.0 : force_demand_N[at]);
      const double a = (pid.update(error) + force) / mass_kg;
      x += v * period_s + 0.5 * a * period_s * period_s;
      v += a * period_s;
    }
  }
  const Eigen::Map<const Eigen::VectorXd> e(tracking_error_m.data(), n);
  // Least squares by the normal equations (the regressors are many rows of
  // few columns), with a ridge far below every column's scale so that shapes
  // nearly alike (a slow harmonic and the B-spline) do not make them singular.
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(columns, columns);
  normal.selfadjointView<Eigen::Lower>().rankUpdate(regressors.transpose());
  normal.triangularView<Eigen::StrictlyUpper>() = normal.transpose();
  const double ridge = 1e-10 * normal.diagonal().mean() + std::numeric_limits<double>::min();
  normal.diagonal().array() += ridge;
  const Eigen::VectorXd coefficients = normal.ldlt().solve(regressors.transpose() * e);
  const Eigen::VectorXd fitted = regressors * coefficients;
  TrackingSplit split;
  split.harmonics = harmonics;
  split.regressors = columns;
  split.total_m2 = e.squaredNorm() / static_cast<double>(n);
  split.rest_m2 = (e - fitted).squaredNorm() / static_cast<double>(n);
  split.commutation_m2 = split.total_m2 - split.rest_m2;  // what the fit explains
  return split;
}

}  // namespace clm::control
