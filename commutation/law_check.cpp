#include "commutation/law_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace clm {
namespace {

LawCheck too_costly(std::int64_t cost, double loop_rate_hz) {
  const std::int64_t budget = law_cost_budget(loop_rate_hz);
  if (cost <= budget) return {};
  LawCheck check;
  check.verdict = LawVerdict::kTooCostly;
  check.value = static_cast<double>(cost);
  check.upper = static_cast<double>(budget);
  check.loop_rate_hz = loop_rate_hz;
  return check;
}

/// kGainNotFinite or kGainOutOfRange for one coil set's motor constant, or accepted.
LawCheck judge_gain(double gain_N_per_A, int coil_set, double position_m, const LawLimits& limits) {
  LawCheck check;
  check.coil_set = coil_set;
  check.position_m = position_m;
  check.value = gain_N_per_A;
  check.lower = limits.nominal_motor_constant_N_per_A / kGainFactorLimit;
  check.upper = limits.nominal_motor_constant_N_per_A * kGainFactorLimit;
  if (!std::isfinite(gain_N_per_A)) {
    check.verdict = LawVerdict::kGainNotFinite;
  } else if (!(gain_N_per_A >= check.lower && gain_N_per_A <= check.upper)) {
    check.verdict = LawVerdict::kGainOutOfRange;
  }
  return check;
}

}  // namespace

std::int64_t network_cost(const Network& network) {
  std::int64_t cost = 0;
  for (std::size_t i = 0; i < network.layers.size(); ++i) {
    const auto& weights = network.layers[i].weights;
    cost += static_cast<std::int64_t>(weights.rows()) * static_cast<std::int64_t>(weights.cols());
    if (i + 1 < network.layers.size()) cost += static_cast<std::int64_t>(weights.rows()) * kTanhMultiplyAdds;
  }
  return cost;
}

std::int64_t model_law_cost(const ElectromagneticModel& model) {
  std::int64_t cost = kSinCosMultiplyAdds + kInverseMultiplyAdds;
  if (model.kind == ModelKind::kPgnn) {
    cost += kRecurrenceMultiplyAddsPerOrder * model.harmonics.max_order();
  } else {
    cost += kSplineBasisMultiplyAdds;
  }
  for (const CoilSetModel& part : model.coil_sets) {
    cost += kPhysicsMultiplyAdds + kInverseMultiplyAddsPerCoilSet;
    if (model.kind == ModelKind::kPgnn) {
      cost += network_cost(part.column_a) + network_cost(part.column_b) + network_cost(part.cogging);
      cost += kGainHarmonicMultiplyAdds * static_cast<std::int64_t>(model.harmonics.gain.size()) +
              kCoggingHarmonicMultiplyAdds * static_cast<std::int64_t>(model.harmonics.cogging.size());
    } else {
      cost += 3 * kSplineMultiplyAdds;
    }
  }
  return cost;
}

std::int64_t classical_law_cost(int coil_sets) {
  return kSinCosMultiplyAdds + static_cast<std::int64_t>(coil_sets) * kClassicalMultiplyAddsPerCoilSet;
}

std::int64_t law_cost_budget(double loop_rate_hz) {
  return static_cast<std::int64_t>(std::floor(kConservativeMultiplyAddsPerSecond * kLawShareOfPeriod / loop_rate_hz));
}

double driving_force_gain_N_per_A(const CoilGain& gain) noexcept {
  const double a = gain(0, 0);
  const double b = gain(0, 1);
  return std::sqrt(a * a - a * b + b * b);  // a² − ab + b² ≥ (a² + b²)/2 ≥ 0
}

std::string describe(const LawCheck& check) {
  char text[160];
  switch (check.verdict) {
    case LawVerdict::kAccepted: return "";
    case LawVerdict::kTooCostly:
      std::snprintf(text, sizeof text, "costs %.0f multiply-adds per cycle, budget %.0f at %g Hz", check.value,
                    check.upper, check.loop_rate_hz);
      return text;
    case LawVerdict::kGainNotFinite:
    case LawVerdict::kGainOutOfRange: {
      char where[48] = "";
      if (!std::isnan(check.position_m)) std::snprintf(where, sizeof where, " at y = %.6g m", check.position_m);
      std::snprintf(text, sizeof text, "coil set %d%s: motor constant %.4g N/A outside [%.4g, %.4g] N/A",
                    check.coil_set, where, check.value, check.lower, check.upper);
      return text;
    }
  }
  return "";
}

LawCheck check_model_law(const ElectromagneticModel& model, const LawLimits& limits) {
  if (LawCheck cost = too_costly(model_law_cost(model), limits.loop_rate_hz); !cost.accepted()) return cost;
  // Where the model was identified: a PGNN's data map to inputs [−1, 1]
  // (normalisation_for), a spline's knots span its data. Beyond, a model
  // extrapolates (docs/servod.md, "What a law may cost and mean").
  const bool pgnn = model.kind == ModelKind::kPgnn;
  double low_m = std::max(limits.stroke_min_m, pgnn ? model.normalisation.offset_m - model.normalisation.scale_m
                                                     : model.spline_basis.start_m);
  double high_m = std::min(limits.stroke_max_m, pgnn ? model.normalisation.offset_m + model.normalisation.scale_m
                                                      : model.spline_basis.end_m);
  if (!(high_m >= low_m)) {  // identified off the stroke: the whole stroke
    low_m = limits.stroke_min_m;
    high_m = limits.stroke_max_m;
  }
  const double range_m = high_m - low_m;
  const double wanted = std::ceil(range_m / model.pole_pitch_m * kGainSamplesPerPolePitch);
  const int intervals = std::clamp(std::isfinite(wanted) ? static_cast<int>(std::min(wanted, 1e9)) : kMaxGainSamples, 1,
                                   kMaxGainSamples - 1);
  for (int k = 0; k <= intervals; ++k) {
    const double position_m = low_m + range_m * k / intervals;
    for (int l = 0; l < model.coil_set_count(); ++l) {
      CoilGain gain;
      Wrench cogging;
      model.evaluate_coil_set(l, position_m, gain, cogging);
      if (LawCheck check = judge_gain(driving_force_gain_N_per_A(gain), l + 1, position_m, limits);
          !check.accepted()) {
        return check;
      }
    }
  }
  return {};
}

LawCheck check_classical_law(std::span<const ClassicalEstimate> estimates, const LawLimits& limits) {
  if (LawCheck cost = too_costly(classical_law_cost(static_cast<int>(estimates.size())), limits.loop_rate_hz);
      !cost.accepted()) {
    return cost;
  }
  for (std::size_t l = 0; l < estimates.size(); ++l) {
    if (LawCheck check = judge_gain(estimates[l].motor_constant_N_per_A, static_cast<int>(l) + 1,
                                    std::numeric_limits<double>::quiet_NaN(), limits);
        !check.accepted()) {
      return check;
    }
  }
  return {};
}

}  // namespace clm
