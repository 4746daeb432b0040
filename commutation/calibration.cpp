#include "commutation/calibration.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "commutation/elementary.hpp"
#include "commutation/transform.hpp"

namespace clm {
namespace {

void check_group(const CalibrationGroup& group, const char* name) {
  const auto n = group.position_m.size();
  if (n == 0) throw CalibrationError(std::string(name) + " group has no samples");
  if (group.magnitude_N.size() != n || group.driving_force_N.size() != n) {
    throw CalibrationError(std::string(name) + " group: position, magnitude and force have different lengths");
  }
}

double sum_squares(std::span<const double> values) {
  double sum = 0.0;
  for (double v : values) sum += v * v;
  return sum;
}

}  // namespace

double separation_condition(double delta_1_rad, double delta_2_rad) {
  const double separation = delta_2_rad - delta_1_rad;
  Eigen::Matrix2d map;
  map << 1.0, 0.0, elementary::cos(separation), elementary::sin(separation);
  const Eigen::Vector2d singular = Eigen::JacobiSVD<Eigen::Matrix2d>(map).singularValues();
  return singular(1) > 0.0 ? singular(0) / singular(1) : std::numeric_limits<double>::infinity();
}

std::vector<std::string> calibration_warnings(const double gain_ratio[2], const CalibrationQuality& quality) {
  std::vector<std::string> warnings;
  char text[200];
  for (int g = 0; g < 2; ++g) {
    const double relative = quality.gain_ratio_standard_error[g] / std::abs(gain_ratio[g]);
    if (!(relative <= kMaxGainRatioRelativeError)) {
      std::snprintf(text, sizeof text,
                    "group %d: the gain ratio is known to %.0f %% only: the commanded force hardly varies, or the "
                    "sensor is noisy", g + 1, 100.0 * relative);
      warnings.emplace_back(text);
    }
    if (!(quality.offset_inflation[g] <= kMaxOffsetInflation)) {
      std::snprintf(text, sizeof text,
                    "group %d: the fitted offset inflates the gain ratio's variance %.1f-fold: the command moves "
                    "with the position", g + 1, quality.offset_inflation[g]);
      warnings.emplace_back(text);
    }
  }
  if (!(quality.separation_condition <= kMaxSeparationCondition)) {
    std::snprintf(text, sizeof text,
                  "the two phase offsets separate k and zeta poorly (condition %.0f; pi/2 apart gives 1)",
                  quality.separation_condition);
    warnings.emplace_back(text);
  }
  return warnings;
}

void calibration_update(double drive_motor_constant_N_per_A, double drive_phase_offset_rad,
                        double delta_1_rad, double c_1, double delta_2_rad, double c_2,
                        double& motor_constant_N_per_A, double& phase_offset_rad) {
  // ĉ_i = (k/k̂)·cos(φ − D_i) with φ = ζ − ζ̂_1, D_1 = 0, D_2 = δ_2 − δ_1, so
  // (k/k̂)·cos φ = ĉ_1 and (k/k̂)·sin φ = (ĉ_2 − ĉ_1·cos D)/sin D.
  const double separation = delta_2_rad - delta_1_rad;
  const double sin_separation = elementary::sin(separation);
  if (std::abs(sin_separation) < 1e-6) {
    throw CalibrationError("the two phase offsets differ by a multiple of pi (delta_1 = " +
                           std::to_string(delta_1_rad) + " rad, delta_2 = " + std::to_string(delta_2_rad) +
                           " rad); they cannot separate k and zeta");
  }
  const double ratio_cos = c_1;
  const double ratio_sin = (c_2 - c_1 * elementary::cos(separation)) / sin_separation;
  const double phi = elementary::atan2(ratio_sin, ratio_cos);
  motor_constant_N_per_A = std::hypot(ratio_cos, ratio_sin) * drive_motor_constant_N_per_A;
  phase_offset_rad = wrap_angle_rad(drive_phase_offset_rad + delta_1_rad + phi);
}

CalibrationResult calibrate_classical(double drive_motor_constant_N_per_A, double drive_phase_offset_rad,
                                      const CalibrationGroup& first, const CalibrationGroup& second) {
  check_group(first, "first");
  check_group(second, "second");
  CalibrationResult result;
  const CalibrationGroup* groups[2] = {&first, &second};
  for (int g = 0; g < 2; ++g) {
    const auto& group = *groups[g];
    const double denominator = sum_squares(group.magnitude_N);
    if (denominator <= 0.0) throw CalibrationError("a group's commanded magnitude is zero throughout");
    double numerator = 0.0;
    for (std::size_t t = 0; t < group.magnitude_N.size(); ++t) {
      numerator += group.driving_force_N[t] * group.magnitude_N[t];
    }
    const double c = numerator / denominator;  // eq. (14)
    double residual = 0.0;
    for (std::size_t t = 0; t < group.magnitude_N.size(); ++t) {
      const double e = group.driving_force_N[t] - c * group.magnitude_N[t];
      residual += e * e;
    }
    const auto n = static_cast<double>(group.magnitude_N.size());
    result.gain_ratio[g] = c;
    result.residual_rms_N[g] = std::sqrt(residual / n);
    result.quality.gain_ratio_standard_error[g] = std::sqrt(residual / std::max(1.0, n - 1.0) / denominator);
  }
  result.quality.separation_condition = separation_condition(first.delta_rad, second.delta_rad);
  calibration_update(drive_motor_constant_N_per_A, drive_phase_offset_rad, first.delta_rad,
                     result.gain_ratio[0], second.delta_rad, result.gain_ratio[1],
                     result.motor_constant_N_per_A, result.phase_offset_rad);
  return result;
}

CalibrationResult calibrate_classical_offset_robust(double drive_motor_constant_N_per_A,
                                                    double drive_phase_offset_rad,
                                                    const CalibrationGroup& first,
                                                    const CalibrationGroup& second,
                                                    const UniformCubicBasis& offset_basis,
                                                    double offset_ridge) {
  check_group(first, "first");
  check_group(second, "second");
  const int basis_size = offset_basis.size();
  const int unknowns = 2 + basis_size;  // ĉ_1, ĉ_2, offset coefficients
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(unknowns, unknowns);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns);
  const CalibrationGroup* groups[2] = {&first, &second};
  double total_samples = 0.0;
  for (int g = 0; g < 2; ++g) {
    const auto& group = *groups[g];
    for (std::size_t t = 0; t < group.position_m.size(); ++t) {
      // Regressor: [m·(g==0), m·(g==1), b_j(y)...]; only 5 entries are non-zero.
      const auto span = offset_basis.evaluate(group.position_m[t]);
      int index[5] = {g, 2 + span.first, 3 + span.first, 4 + span.first, 5 + span.first};
      double value[5] = {group.magnitude_N[t], span.value[0], span.value[1], span.value[2], span.value[3]};
      for (int r = 0; r < 5; ++r) {
        rhs(index[r]) += value[r] * group.driving_force_N[t];
        for (int c = 0; c < 5; ++c) normal(index[r], index[c]) += value[r] * value[c];
      }
    }
    total_samples += static_cast<double>(group.position_m.size());
  }
  for (int j = 0; j < basis_size; ++j) normal(2 + j, 2 + j) += offset_ridge * total_samples;
  if (normal(0, 0) <= 0.0 || normal(1, 1) <= 0.0) {
    throw CalibrationError("a group's commanded magnitude is zero throughout");
  }
  const Eigen::LDLT<Eigen::MatrixXd> factor = normal.ldlt();
  const Eigen::VectorXd solution = factor.solve(rhs);
  if (!solution.allFinite()) throw CalibrationError("offset-robust calibration is singular");

  CalibrationResult result;
  double residual_total = 0.0;
  for (int g = 0; g < 2; ++g) {
    const auto& group = *groups[g];
    double residual = 0.0;
    for (std::size_t t = 0; t < group.position_m.size(); ++t) {
      const auto span = offset_basis.evaluate(group.position_m[t]);
      double fit = solution(g) * group.magnitude_N[t];
      for (int k = 0; k < 4; ++k) fit += solution(2 + span.first + k) * span.value[k];
      const double e = group.driving_force_N[t] - fit;
      residual += e * e;
    }
    result.gain_ratio[g] = solution(g);
    result.residual_rms_N[g] = std::sqrt(residual / static_cast<double>(group.position_m.size()));
    residual_total += residual;
  }
  // Standard errors from σ²·(normal)⁻¹ (the ridge included); the inflation
  // compares each with the error the ratio would have alone, σ²/Σ m².
  const double variance = residual_total / std::max(1.0, total_samples - unknowns);
  const Eigen::MatrixXd covariance = factor.solve(Eigen::MatrixXd::Identity(unknowns, unknowns));
  for (int g = 0; g < 2; ++g) {
    result.quality.gain_ratio_standard_error[g] = std::sqrt(variance * std::max(0.0, covariance(g, g)));
    result.quality.offset_inflation[g] = covariance(g, g) * normal(g, g);
  }
  result.quality.separation_condition = separation_condition(first.delta_rad, second.delta_rad);
  calibration_update(drive_motor_constant_N_per_A, drive_phase_offset_rad, first.delta_rad,
                     result.gain_ratio[0], second.delta_rad, result.gain_ratio[1],
                     result.motor_constant_N_per_A, result.phase_offset_rad);
  return result;
}

}  // namespace clm
