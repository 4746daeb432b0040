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

TrackingSplit split_tracking_error(std::span<const double> position_m, std::span<const double> feedforward_N,
                                   std::span<const double> tracking_error_m, double pole_pitch_m, const PidGains& gains, double mass_kg, double period_s,
                                   int harmonics) {
  const auto n = static_cast<Eigen::Index>(position_m.size());
  if (position_m.size() != tracking_error_m.size() || position_m.size() != feedforward_N.size()) {
    throw std::invalid_argument("split_tracking_error: " + std::to_string(position_m.size()) + " positions, " +
                                std::to_string(feedforward_N.size()) + " feedforward forces and " +
                                std::to_string(tracking_error_m.size()) + " tracking errors");
  }
  if (!(pole_pitch_m > 0.0) || !(mass_kg > 0.0) || !(period_s > 0.0) || !(harmonics > 0)) {
    throw std::invalid_argument("split_tracking_error: pole pitch, mass, period and harmonics must be positive");
  }
  double low_m = 0.0, high_m = 0.0;
  for (std::size_t k = 0; k < position_m.size(); ++k) {
    const double y = position_m[k];
    if (!std::isfinite(y) || !std::isfinite(feedforward_N[k])) {
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
  const int columns = 2 * shapes;  // each shape alone, and times the feedforward
  if (n < 4 * columns) {
    throw std::invalid_argument("split_tracking_error: " + std::to_string(n) + " samples for " +
                                std::to_string(columns) + " regressors (at least 4 per regressor)");
  }
  // The shapes at the recorded positions, once.
  Eigen::MatrixXd shapes_at(n, shapes);
  const double angle_per_m = kTwoPi / pole_pitch_m;
  for (Eigen::Index k = 0; k < n; ++k) {
    const double y = position_m[static_cast<std::size_t>(k)];
    for (int h = 0; h < harmonics; ++h) {
      const double angle = angle_per_m * (h + 1) * y;
      shapes_at(k, 2 * h) = elementary::cos(angle);
      shapes_at(k, 2 * h + 1) = elementary::sin(angle);
    }
    shapes_at.row(k).tail(spline.size()).setZero();
    const UniformCubicBasis::Span span = spline.evaluate(y);
    for (int j = 0; j < 4; ++j) {
      const int function = span.first + j;
      if (function >= 0 && function < spline.size()) {
        shapes_at(k, 2 * harmonics + function) = span.value[static_cast<std::size_t>(j)];
      }
    }
  }
  // Each force shape at the motor through the loop: the PID closed around
  // the mass, the force held over each period (exact for a constant force:
  // x += vT + aT²/2, v += aT). The regressor is the tracking error it
  // causes, −x.
  Eigen::MatrixXd regressors(n, columns);
  for (int column = 0; column < columns; ++column) {
    PidController pid(gains, period_s);
    double x = 0.0, v = 0.0;
    for (Eigen::Index k = 0; k < n; ++k) {
      regressors(k, column) = -x;
      const double force = column < shapes ? shapes_at(k, column)
                                           : shapes_at(k, column - shapes) * feedforward_N[static_cast<std::size_t>(k)];
      const double a = (pid.update(-x) + force) / mass_kg;
      x += v * period_s + 0.5 * a * period_s * period_s;
      v += a * period_s;
    }
  }
  const Eigen::Map<const Eigen::VectorXd> e(tracking_error_m.data(), n);
  // Least squares by the normal equations (many rows of few columns), the
  // columns scaled to unit norm and a ridge relative to that: shapes times
  // a feedforward that is itself nearly a function of position (m·r'' on a
  // repeated stroke, the friction at constant speed) are nearly the shapes
  // alone.
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(columns, columns);
  normal.selfadjointView<Eigen::Lower>().rankUpdate(regressors.transpose());
  normal.triangularView<Eigen::StrictlyUpper>() = normal.transpose();
  const Eigen::VectorXd scale = (normal.diagonal().array() + std::numeric_limits<double>::min()).rsqrt().matrix();
  normal = scale.asDiagonal() * normal * scale.asDiagonal();
  normal.diagonal().array() += kTrackingSplitRidge;
  const Eigen::VectorXd coefficients =
      scale.asDiagonal() * normal.ldlt().solve(scale.asDiagonal() * (regressors.transpose() * e));
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
