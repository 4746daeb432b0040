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

namespace {

/// The grid of kGainSamplesPerPolePitch over the stroke, both ends: calls
/// `judge(position_m)` at each point from the lower end; the first refusal.
template <class Judge>
LawCheck over_stroke(double pole_pitch_m, const LawLimits& limits, Judge judge) {
  const double low_m = limits.stroke_min_m;
  const double range_m = limits.stroke_max_m - limits.stroke_min_m;
  const double wanted = std::ceil(range_m / pole_pitch_m * kGainSamplesPerPolePitch);
  const int intervals = std::clamp(std::isfinite(wanted) ? static_cast<int>(std::min(wanted, 1e9)) : kMaxGainSamples, 1,
                                   kMaxGainSamples - 1);
  for (int k = 0; k <= intervals; ++k) {
    if (LawCheck check = judge(low_m + range_m * k / intervals); !check.accepted()) return check;
  }
  return {};
}

/// Every coil set's motor constant of `model` at `position_m`.
LawCheck judge_model_gains(const ElectromagneticModel& model, double position_m, const LawLimits& limits) {
  for (int l = 0; l < model.coil_set_count(); ++l) {
    CoilGain gain;
    Wrench cogging;
    model.evaluate_coil_set(l, position_m, gain, cogging);
    if (LawCheck check = judge_gain(driving_force_gain_N_per_A(gain), l + 1, position_m, limits); !check.accepted()) {
      return check;
    }
  }
  return {};
}

}  // namespace

std::int64_t blended_law_cost(const ElectromagneticModel& model) {
  return model_law_cost(model) + classical_law_cost(model.coil_set_count()) + kBlendMultiplyAdds +
         kBlendMultiplyAddsPerCoilSet * model.coil_set_count();
}

LawCheck check_model_law(const ElectromagneticModel& model, const LawLimits& limits) {
  if (LawCheck cost = too_costly(model_law_cost(model), limits.loop_rate_hz); !cost.accepted()) return cost;
  return over_stroke(model.pole_pitch_m, limits,
                     [&](double position_m) { return judge_model_gains(model, position_m, limits); });
}

LawCheck check_blended_law(const ElectromagneticModel& model, std::span<const ClassicalEstimate> outside,
                           const LawLimits& limits) {
  if (LawCheck cost = too_costly(blended_law_cost(model), limits.loop_rate_hz); !cost.accepted()) return cost;
  const IdentifiedRange range = identified_range(model);
  const double margin_m = kBlendMarginPolePitches * model.pole_pitch_m;
  return over_stroke(model.pole_pitch_m, limits, [&](double position_m) {
    const double weight = model_law_weight(range, margin_m, position_m);
    if (weight > 0.0) {
      if (LawCheck check = judge_model_gains(model, position_m, limits); !check.accepted()) return check;
    }
    if (weight < 1.0) {
      for (std::size_t l = 0; l < outside.size(); ++l) {
        if (LawCheck check = judge_gain(outside[l].motor_constant_N_per_A, static_cast<int>(l) + 1, position_m, limits);
            !check.accepted()) {
          return check;
        }
      }
    }
    return LawCheck{};
  });
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
