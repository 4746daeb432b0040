#include "commutation/model.hpp"

#include <cmath>
#include <tuple>

#include "commutation/elementary.hpp"

namespace clm {
namespace {

Eigen::Vector3d spline_value(const SplineCoefficients& coefficients, const UniformCubicBasis::Span& span) {
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  for (int k = 0; k < 4; ++k) value += span.value[k] * coefficients.col(span.first + k);
  return value;
}

}  // namespace

std::string harmonic_orders_error(const std::vector<int>& orders, int lowest) {
  for (std::size_t k = 0; k < orders.size(); ++k) {
    const int previous = k == 0 ? lowest - 1 : orders[k - 1];
    if (orders[k] <= previous || orders[k] > kMaxHarmonicOrder) {
      return "need ascending distinct orders in " + std::to_string(lowest) + ".." + std::to_string(kMaxHarmonicOrder);
    }
  }
  return {};
}

void add_physics_harmonics(const HarmonicOrders& orders, const CoilSetModel& part, const double* cos_n,
                           const double* sin_n, CoilGain& gain, Wrench& cogging) noexcept {
  for (std::size_t k = 0; k < orders.gain.size(); ++k) {
    const auto n = static_cast<std::size_t>(orders.gain[k]);
    const auto first = static_cast<Eigen::Index>(4 * k);
    gain += part.gain_harmonics_N_per_A.middleCols<2>(first) * cos_n[n] +
            part.gain_harmonics_N_per_A.middleCols<2>(first + 2) * sin_n[n];
  }
  for (std::size_t k = 0; k < orders.cogging.size(); ++k) {
    const auto m = static_cast<std::size_t>(orders.cogging[k]);
    const auto first = static_cast<Eigen::Index>(2 * k);
    cogging += part.cogging_harmonics_N.col(first) * cos_n[m] + part.cogging_harmonics_N.col(first + 1) * sin_n[m];
  }
}

namespace {

// What every coil set needs of the position, computed once per evaluation.
struct PositionFeatures {
  double cos_theta;
  double sin_theta;
  double network_input;
  UniformCubicBasis::Span span;
  double cos_n[kMaxHarmonicOrder + 1];  // the physics part's harmonics
  double sin_n[kMaxHarmonicOrder + 1];
};

PositionFeatures features(const ElectromagneticModel& model, double position_m) {
  const double theta = electrical_angle_rad(position_m, model.pole_pitch_m);
  const auto [sin_theta, cos_theta] = elementary::sin_cos(theta);
  PositionFeatures f{cos_theta, sin_theta, 0.0, {}, {}, {}};
  if (model.kind == ModelKind::kPgnn) {
    f.network_input = model.normalisation.apply(position_m);
    angle_harmonics(f.cos_theta, f.sin_theta, model.harmonics.max_order(), f.cos_n, f.sin_n);
  } else {
    f.span = model.spline_basis.evaluate(position_m);
  }
  return f;
}

void evaluate_part(const ElectromagneticModel& model, const CoilSetModel& part, const PositionFeatures& f,
                   CoilGain& gain, Wrench& cogging) {
  gain = part.a_N_per_A * f.cos_theta + part.b_N_per_A * f.sin_theta;
  if (model.kind == ModelKind::kPgnn) {
    gain.col(0) += part.column_a.evaluate(f.network_input);
    gain.col(1) += part.column_b.evaluate(f.network_input);
    cogging = part.cogging.evaluate(f.network_input);
    add_physics_harmonics(model.harmonics, part, f.cos_n, f.sin_n, gain, cogging);
  } else {
    gain.col(0) += spline_value(part.column_a_spline, f.span);
    gain.col(1) += spline_value(part.column_b_spline, f.span);
    cogging = spline_value(part.cogging_spline, f.span);
  }
}

}  // namespace

void ElectromagneticModel::evaluate_coil_set(int coil_set, double position_m, CoilGain& gain,
                                             Wrench& cogging) const noexcept {
  evaluate_part(*this, coil_sets[static_cast<std::size_t>(coil_set)], features(*this, position_m), gain, cogging);
}

void ElectromagneticModel::evaluate(double position_m, StackedGain& gain, Wrench& cogging) const noexcept {
  const int count = coil_set_count();
  gain.resize(3, 2 * count);
  cogging.setZero();
  const PositionFeatures f = features(*this, position_m);
  for (int l = 0; l < count; ++l) {
    CoilGain coil_gain;
    Wrench coil_cogging;
    evaluate_part(*this, coil_sets[static_cast<std::size_t>(l)], f, coil_gain, coil_cogging);
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
    // The spacing too: end − start can overflow to infinity (start −1e308,
    // end 1e308) or the spacing underflow to zero (start and end a few ulp
    // apart near the smallest normal number), and evaluate() would then turn
    // a NaN into a knot index.
    const double spacing_m = spline_basis.spacing_m();
    if (spline_basis.intervals < 1 || !(spline_basis.end_m > spline_basis.start_m) ||
        !std::isfinite(spline_basis.start_m) || !std::isfinite(spline_basis.end_m) || !(spacing_m > 0.0) ||
        !std::isfinite(spacing_m)) {
      throw ModelError("spline knots: need start_m < end_m, at least one interval and a finite, non-zero knot spacing");
    }
  }
  if (kind != ModelKind::kPgnn && !harmonics.empty()) throw ModelError("harmonic orders: a PGNN's only");
  for (const auto& [orders, lowest, name] : {std::tuple{&harmonics.gain, kLowestGainHarmonic, "gain"},
                                             std::tuple{&harmonics.cogging, kLowestCoggingHarmonic, "cogging"}}) {
    const std::string error = harmonic_orders_error(*orders, lowest);
    if (!error.empty()) throw ModelError(std::string("harmonic orders, ") + name + ": " + error);
  }
  for (int l = 0; l < count; ++l) {
    const auto& model = coil_sets[static_cast<std::size_t>(l)];
    const std::string where = "coil set " + std::to_string(l + 1) + ": ";
    if (!model.a_N_per_A.allFinite() || !model.b_N_per_A.allFinite()) throw ModelError(where + "A or B not finite");
    if (model.gain_harmonics_N_per_A.cols() != 4 * static_cast<Eigen::Index>(harmonics.gain.size()) ||
        model.cogging_harmonics_N.cols() != 2 * static_cast<Eigen::Index>(harmonics.cogging.size())) {
      throw ModelError(where + "harmonic coefficients do not match the harmonic orders");
    }
    if (!model.gain_harmonics_N_per_A.allFinite() || !model.cogging_harmonics_N.allFinite()) {
      throw ModelError(where + "harmonic coefficients not finite");
    }
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

bool FusedPgnnEvaluator::supports(const ElectromagneticModel& model) {
  if (model.kind != ModelKind::kPgnn) return false;
  for (const auto& part : model.coil_sets) {
    for (const Network* network : {&part.column_a, &part.column_b, &part.cogging}) {
      if (network->layers.size() != 2) return false;
    }
  }
  return true;
}

FusedPgnnEvaluator::FusedPgnnEvaluator(const ElectromagneticModel& model) : model_(&model) {
  if (!supports(model)) throw ModelError("fused evaluation needs a PGNN with one hidden layer per network");
  int total = 0;
  for (const auto& part : model.coil_sets) {
    for (const Network* network : {&part.column_a, &part.column_b, &part.cogging}) {
      total += static_cast<int>(network->layers[0].biases.size());
    }
  }
  const auto padded = static_cast<std::size_t>((total + 3) / 4 * 4);
  input_weight_.assign(padded, 0.0);
  input_bias_.assign(padded, 0.0);
  hidden_.assign(padded, 0.0);
  output_weights_.assign(4 * padded, 0.0);
  int first = 0;
  for (const auto& part : model.coil_sets) {
    for (const Network* network : {&part.column_a, &part.column_b, &part.cogging}) {
      const auto& hidden = network->layers[0];
      const auto width = static_cast<int>(hidden.biases.size());
      const auto& last = network->layers[1];
      for (int n = 0; n < width; ++n) {
        const auto neuron = static_cast<std::size_t>(first + n);
        input_weight_[neuron] = hidden.weights(n, 0);
        input_bias_[neuron] = hidden.biases[n];
        for (int r = 0; r < 3; ++r) output_weights_[4 * neuron + static_cast<std::size_t>(r)] = last.weights(r, n);
      }
      outputs_.push_back({first, width, {last.biases[0], last.biases[1], last.biases[2]}});
      first += width;
    }
  }
}

void FusedPgnnEvaluator::evaluate(double position_m, StackedGain& gain, Wrench& cogging) const noexcept {
  const auto& model = *model_;
  const int count = model.coil_set_count();
  const double theta = electrical_angle_rad(position_m, model.pole_pitch_m);
  const auto [s, c] = elementary::sin_cos(theta);
  const double input = model.normalisation.apply(position_m);
  double* hidden = hidden_.data();
  const auto padded = static_cast<int>(hidden_.size());
  for (int k = 0; k < padded; ++k) hidden[k] = input_weight_[static_cast<std::size_t>(k)] * input +
                                               input_bias_[static_cast<std::size_t>(k)];
  elementary::tanh_array(hidden, hidden, padded);
  gain.resize(3, 2 * count);
  cogging.setZero();
  double cos_n[kMaxHarmonicOrder + 1];
  double sin_n[kMaxHarmonicOrder + 1];
  angle_harmonics(c, s, model.harmonics.max_order(), cos_n, sin_n);
  for (int l = 0; l < count; ++l) {
    const auto& part = model.coil_sets[static_cast<std::size_t>(l)];
    CoilGain coil_gain = part.a_N_per_A * c + part.b_N_per_A * s;
    Wrench harmonic_cogging = Wrench::Zero();
    add_physics_harmonics(model.harmonics, part, cos_n, sin_n, coil_gain, harmonic_cogging);
    gain.middleCols<2>(2 * l) = coil_gain;
    cogging += harmonic_cogging;
    for (int n = 0; n < 3; ++n) {
      const Output& out = outputs_[static_cast<std::size_t>(3 * l + n)];
      // Four independent lanes (the fourth weight is zero): the compiler keeps
      // them in two vector registers.
      double v[4] = {out.bias[0], out.bias[1], out.bias[2], 0.0};
      const double* h = hidden + out.first;
      const double* w = output_weights_.data() + 4 * static_cast<std::size_t>(out.first);
      for (int k = 0; k < out.width; ++k) {
        for (int r = 0; r < 4; ++r) v[r] += w[4 * k + r] * h[k];
      }
      if (n < 2) {
        gain(0, 2 * l + n) += v[0];
        gain(1, 2 * l + n) += v[1];
        gain(2, 2 * l + n) += v[2];
      } else {
        cogging += Wrench(v[0], v[1], v[2]);
      }
    }
  }
  cogging /= static_cast<double>(count);  // eq. (35)
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
