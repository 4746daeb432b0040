#include "commutation/bspline.hpp"

#include <algorithm>
#include <cmath>

namespace clm {

UniformCubicBasis::Span UniformCubicBasis::evaluate(double position_m) const {
  const double u = (std::clamp(position_m, start_m, end_m) - start_m) / spacing_m();
  const int interval = std::clamp(static_cast<int>(std::floor(u)), 0, intervals - 1);
  const double t = u - interval;
  const double s = 1.0 - t;
  Span span;
  span.first = interval;
  span.value[0] = s * s * s / 6.0;
  span.value[1] = (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0;
  span.value[2] = (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0;
  span.value[3] = t * t * t / 6.0;
  return span;
}

}  // namespace clm
