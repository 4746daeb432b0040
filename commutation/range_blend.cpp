#include "commutation/range_blend.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "commutation/transform.hpp"

namespace clm {

IdentifiedRange identified_range(const ElectromagneticModel& model) noexcept {
  if (model.kind == ModelKind::kPgnn) {
    const double half_m = std::abs(model.normalisation.scale_m);
    return {model.normalisation.offset_m - half_m, model.normalisation.offset_m + half_m};
  }
  return {model.spline_basis.start_m, model.spline_basis.end_m};
}

double model_law_weight(const IdentifiedRange& range, double margin_m, double position_m) noexcept {
  const double outside_m = std::max(range.low_m - position_m, position_m - range.high_m);
  if (!(outside_m > 0.0)) return 1.0;  // inside, both ends included
  if (outside_m >= margin_m) return 0.0;
  const double s = outside_m / margin_m;
  return 1.0 - s * s * (3.0 - 2.0 * s);
}

RangeBlendedCommutator::RangeBlendedCommutator(const ElectromagneticModel& model,
                                               std::span<const ClassicalEstimate> outside,
                                               const DriveCommutation& drive, const ModelCommutatorOptions& options)
    : model_law_(model, drive, options),
      classical_law_(outside, model.pole_pitch_m, drive, options.phase_convention),
      range_(identified_range(model)),
      margin_m_(kBlendMarginPolePitches * model.pole_pitch_m),
      pole_pitch_m_(model.pole_pitch_m),
      drive_(drive),
      convention_(options.phase_convention) {
  if (static_cast<int>(outside.size()) != model.coil_set_count()) {
    throw std::invalid_argument("blended law: the classical law has " + std::to_string(outside.size()) +
                                " coil sets, the model " + std::to_string(model.coil_set_count()));
  }
  if (!(margin_m_ > 0.0) || !(range_.high_m >= range_.low_m)) {
    throw std::invalid_argument("blended law: the model's identified range or pole pitch is not valid");
  }
  std::copy(outside.begin(), outside.end(), outside_.begin());
}

void RangeBlendedCommutator::commutate(double position_m, const Wrench& desired,
                                       CommutationOutput& out) const noexcept {
  const double w = weight(position_m);
  if (w == 1.0) {
    model_law_.commutate(position_m, desired, out);
    return;
  }
  if (w == 0.0) {
    classical_law_.commutate(position_m, desired, out);
    return;
  }
  // In the margin: both laws, their currents blended (fixed-size storage: no allocation).
  CommutationOutput classical;
  classical_law_.commutate(position_m, desired, classical);
  model_law_.commutate(position_m, desired, out);
  out.currents_A = w * out.currents_A + (1.0 - w) * classical.currents_A;
  out.model_wrench = w * out.model_wrench + (1.0 - w) * classical.model_wrench;
  out.driving_gain_N_per_A = w * out.driving_gain_N_per_A + (1.0 - w) * classical.driving_gain_N_per_A;
  out.current_square_sum_A2 = current_square_sum(out.currents_A);
  const Eigen::Matrix2d gamma_inv = gamma_inverse(drive_, position_m, pole_pitch_m_);
  for (int l = 0; l < out.coil_sets; ++l) {
    out.setpoints[static_cast<std::size_t>(l)] =
        transform_inverse(gamma_inv * out.currents_A.segment<2>(2 * l), convention_);
  }
  // singular_value_ratio and damping_engaged stay the model law's: the classical one has none.
}

}  // namespace clm
