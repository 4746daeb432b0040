#pragma once
// Uniform cubic B-spline basis on an interval, used by the spline model class,
// the offset-robust calibration and the simulator's smooth parasitics.

#include <array>

namespace clm {

/// Uniform cubic B-spline basis on [start_m, end_m] split into `intervals`
/// equal knot intervals: intervals + 3 basis functions. Outside the interval
/// the position is clamped to it (constant extrapolation).
struct UniformCubicBasis {
  double start_m = 0.0;
  double end_m = 1.0;
  int intervals = 1;

  /// Number of basis functions.
  int size() const { return intervals + 3; }
  /// Knot spacing [m].
  double spacing_m() const { return (end_m - start_m) / intervals; }

  /// The four non-zero basis values at `position_m` and the index of the first.
  /// They sum to one.
  struct Span {
    int first = 0;
    std::array<double, 4> value{};
  };
  Span evaluate(double position_m) const;
};

}  // namespace clm
