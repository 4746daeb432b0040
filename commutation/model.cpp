#include "commutation/model.hpp"

#include <cmath>

namespace clm {
namespace {

Eigen::Vector3d spline_value(const SplineCoefficients& coefficients, const UniformCubicBasis::Span& span) {
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  for (int k = 0; k < 4; ++k) value += span.value[k] * coefficients.col(span.first + k);
  return value;
}

}  // namespace

void ElectromagneticModel::evaluate_coil_set(int coil_set, double position_m, CoilGain& gain,
                                             Wrench& cogging) const noexcept {
  const auto& model = coil_sets[static_cast<std::size_t>(coil_set)];
  const double theta = electrical_angle_rad(position_m, pole_pitch_m);
  gain = model.a_N_per_A * std::cos(theta) + model.b_N_per_A * std::sin(theta);
  if (kind == ModelKind::kPgnn) {
    const double input = normalisation.apply(position_m);
    gain.col(0) += model.column_a.evaluate(input);
    gain.col(1) += model.column_b.evaluate(input);
    cogging = model.cogging.evaluate(input);
  } else {
    const auto span = spline_basis.evaluate(position_m);
    gain.col(0) += spline_value(model.column_a_spline, span);
    gain.col(1) += spline_value(model.column_b_spline, span);
    cogging = spline_value(model.cogging_spline, span);
  }
}

void ElectromagneticModel::evaluate(double position_m, StackedGain& gain, Wrench& cogging) const noexcept {
  const int count = coil_set_count();
  gain.resize(3, 2 * count);
  cogging.setZero();
  for (int l = 0; l < count; ++l) {
    CoilGain coil_gain;
    Wrench coil_cogging;
    evaluate_coil_set(l, position_m, coil_gain, coil_cogging);
    gain.middleCols<2>(2 * l) = coil_gain;
    cogging += coil_cogging;
  }
  cogging /= static_cast<double>(count);  // eq. (35): mean of the coil sets' estimates
}

Wrench ElectromagneticModel::predict(double position_m, const CurrentVector& currents_A) const noexcept {
  StackedGain gain;
  Wrench cogging;
  evaluate(position_m, gain, cogging);
  return gain * currents_A + cogging;
}

void ElectromagneticModel::validate() const {
  const int count = coil_set_count();
  if (count < 1 || count > kMaxCoilSets) {
    throw ModelError("coil_sets: " + std::to_string(count) + " coil sets, expected 1.." +
                     std::to_string(kMaxCoilSets));
  }
  if (!(pole_pitch_m > 0.0) || !std::isfinite(pole_pitch_m)) {
    throw ModelError("pole_pitch_m: " + std::to_string(pole_pitch_m) + " is not a positive length");
  }
  if (!(std::isfinite(normalisation.offset_m) && std::isfinite(normalisation.scale_m) && normalisation.scale_m > 0.0)) {
    throw ModelError("normalisation: offset must be finite and scale positive");
  }
  if (kind == ModelKind::kSpline) {
    if (spline_basis.intervals < 1 || !(spline_basis.end_m > spline_basis.start_m) ||
        !std::isfinite(spline_basis.start_m) || !std::isfinite(spline_basis.end_m)) {
      throw ModelError("spline knots: need start_m < end_m and at least one interval");
    }
  }
  for (int l = 0; l < count; ++l) {
    const auto& model = coil_sets[static_cast<std::size_t>(l)];
    const std::string where = "coil set " + std::to_string(l + 1) + ": ";
    if (!model.a_N_per_A.allFinite() || !model.b_N_per_A.allFinite()) throw ModelError(where + "A or B not finite");
    if (kind == ModelKind::kPgnn) {
      const Network* networks[3] = {&model.column_a, &model.column_b, &model.cogging};
      const char* names[3] = {"column_a", "column_b", "cogging"};
      for (int n = 0; n < 3; ++n) {
        const std::string error = networks[n]->shape_error();
        if (!error.empty()) throw ModelError(where + names[n] + " network: " + error);
      }
    } else {
      const SplineCoefficients* splines[3] = {&model.column_a_spline, &model.column_b_spline, &model.cogging_spline};
      const char* names[3] = {"column_a", "column_b", "cogging"};
      for (int n = 0; n < 3; ++n) {
        if (splines[n]->cols() != spline_basis.size()) {
          throw ModelError(where + names[n] + " spline: " + std::to_string(splines[n]->cols()) +
                           " coefficients per row, knot grid needs " + std::to_string(spline_basis.size()));
        }
        if (!splines[n]->allFinite()) throw ModelError(where + names[n] + " spline: non-finite coefficient");
      }
    }
  }
}

ElectromagneticModel make_classical_model(double pole_pitch_m, std::span<const ClassicalCoilSet> coil_sets,
                                          const std::vector<int>& column_hidden_sizes,
                                          const std::vector<int>& cogging_hidden_sizes) {
  ElectromagneticModel model;
  model.kind = ModelKind::kPgnn;
  model.pole_pitch_m = pole_pitch_m;
  for (const auto& coil_set : coil_sets) {
    CoilSetModel part;
    classical_physics_parameters(coil_set, part.a_N_per_A, part.b_N_per_A);
    if (!column_hidden_sizes.empty()) {
      part.column_a = Network::zeros(column_hidden_sizes);
      part.column_b = Network::zeros(column_hidden_sizes);
    }
    if (!cogging_hidden_sizes.empty()) part.cogging = Network::zeros(cogging_hidden_sizes);
    model.coil_sets.push_back(std::move(part));
  }
  return model;
}

}  // namespace clm
