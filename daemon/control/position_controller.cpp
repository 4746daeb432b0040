#include "daemon/control/position_controller.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "commutation/types.hpp"
#include "daemon/control/checks.hpp"

namespace clm::control {

namespace {

void require_non_negative_finite(const char* context, const char* name, double value) {
  if (!(value >= 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string(context) + ": " + name + " must be finite and >= 0, got " +
                                detail::format_number(value));
  }
}

}  // namespace

// ---------------------------------------------------------------------------
// Tuning

PidGains tune_pid(double mass_kg, double bandwidth_hz) {
  detail::require_positive_finite("tune_pid", "mass_kg", mass_kg);
  detail::require_positive_finite("tune_pid", "bandwidth_hz", bandwidth_hz);
  const double crossover_rad_per_s = kTwoPi * bandwidth_hz;
  const double derivative_ratio = std::sqrt(3.0);  // ω_c/ω_d
  const double integrator_ratio = 1.0 / 5.0;       // ω_i/ω_c
  const double lowpass_ratio = 5.0;                // ω_lp/ω_c
  // |C(jω_c)| = k_p·|1 + j(ω_c/ω_d − ω_i/ω_c)| / |1 + jω_c/ω_lp| = m ω_c² (header).
  const double lead = derivative_ratio - integrator_ratio;
  const double kp = mass_kg * crossover_rad_per_s * crossover_rad_per_s *
                    std::sqrt(1.0 + 1.0 / (lowpass_ratio * lowpass_ratio)) / std::sqrt(1.0 + lead * lead);
  const PidGains gains{kp, kp * integrator_ratio * crossover_rad_per_s, kp * derivative_ratio / crossover_rad_per_s,
                       lowpass_ratio * bandwidth_hz};
  // Finite inputs can still overflow (m ω_c² above the largest double): say
  // so here, where mass and bandwidth are known, not in PidController.
  if (!std::isfinite(gains.proportional_N_per_m) || !std::isfinite(gains.integral_N_per_m_s) ||
      !std::isfinite(gains.derivative_N_s_per_m)) {
    throw std::invalid_argument("tune_pid: mass_kg " + detail::format_number(mass_kg) + " kg at bandwidth_hz " +
                                detail::format_number(bandwidth_hz) + " Hz gives non-finite gains (k_p " +
                                detail::format_number(gains.proportional_N_per_m) + " N/m, k_i " +
                                detail::format_number(gains.integral_N_per_m_s) + " N/(m*s))");
  }
  return gains;
}

// ---------------------------------------------------------------------------
// PID

PidController::PidController(const PidGains& gains, double period_s)
    : gains_(gains), period_s_(period_s), integrator_limit_N_(std::numeric_limits<double>::infinity()) {
  constexpr const char* kContext = "PidController";
  require_non_negative_finite(kContext, "proportional_N_per_m", gains.proportional_N_per_m);
  require_non_negative_finite(kContext, "integral_N_per_m_s", gains.integral_N_per_m_s);
  require_non_negative_finite(kContext, "derivative_N_s_per_m", gains.derivative_N_s_per_m);
  detail::require_positive_finite(kContext, "lowpass_hz", gains.lowpass_hz);
  detail::require_positive_finite(kContext, "period_s", period_s);
  set_gains(gains);
}

void PidController::set_gains(const PidGains& gains) noexcept {
  gains_ = gains;
  // Tustin image of 1/(s/ω_lp + 1): (z+1)/((α+1)z − (α−1)), α = 2/(ω_lp T_s).
  const double alpha = 2.0 / (kTwoPi * gains.lowpass_hz * period_s_);
  pole_ = (alpha - 1.0) / (alpha + 1.0);
  input_scale_ = 1.0 / (alpha + 1.0);
  derivative_scale_ = 2.0 * gains.derivative_N_s_per_m / period_s_ / (alpha + 1.0);
}

void PidController::set_integrator_limit_N(double limit_N) {
  if (!(limit_N > 0.0)) {
    throw std::invalid_argument("PidController: integrator limit must be > 0 N (infinity for none), got " +
                                detail::format_number(limit_N));
  }
  integrator_limit_N_ = limit_N;
}

double PidController::update(double error_m) noexcept {
  if (!started_) {
    // Bumpless start: as if the error had been error_m one sample earlier.
    previous_error_m_ = error_m;
    previous_proportional_integral_N_ = gains_.proportional_N_per_m * error_m + integrator_N_;
    started_ = true;
  }
  const double unclamped_N =
      integrator_N_ + 0.5 * gains_.integral_N_per_m_s * period_s_ * (error_m + previous_error_m_);
  integrator_N_ = std::clamp(unclamped_N, -integrator_limit_N_, integrator_limit_N_);
  integrator_limited_ = integrator_N_ != unclamped_N;

  const double proportional_integral_N = gains_.proportional_N_per_m * error_m + integrator_N_;
  proportional_integral_filtered_N_ = pole_ * proportional_integral_filtered_N_ +
                                      input_scale_ * (proportional_integral_N + previous_proportional_integral_N_);
  derivative_filtered_N_ = pole_ * derivative_filtered_N_ + derivative_scale_ * (error_m - previous_error_m_);

  previous_error_m_ = error_m;
  previous_proportional_integral_N_ = proportional_integral_N;
  output_N_ = proportional_integral_filtered_N_ + derivative_filtered_N_;
  return output_N_;
}

void PidController::reset() noexcept {
  started_ = false;
  integrator_limited_ = false;
  previous_error_m_ = 0.0;
  integrator_N_ = 0.0;
  previous_proportional_integral_N_ = 0.0;
  proportional_integral_filtered_N_ = 0.0;
  derivative_filtered_N_ = 0.0;
  output_N_ = 0.0;
}

// ---------------------------------------------------------------------------
// Feedforward

double feedforward_force_N(const FeedforwardParameters& parameters, const ReferenceSample& now,
                           const ReferenceSample& next) noexcept {
  // Eq. (40), δ = (z+1)/2.
  return parameters.mass_kg * 0.5 * (now.acceleration_m_per_s2 + next.acceleration_m_per_s2) +
         parameters.viscous_N_s_per_m * 0.5 * (now.velocity_m_per_s + next.velocity_m_per_s) +
         parameters.coulomb_N * 0.5 * (detail::sign(now.velocity_m_per_s) + detail::sign(next.velocity_m_per_s));
}

FeedforwardParameters identify_feedforward(std::span<const ReferenceSample> reference,
                                           std::span<const double> force_demand_N) {
  return fit_feedforward(reference, force_demand_N).parameters;
}

FeedforwardFit fit_feedforward(std::span<const ReferenceSample> reference, std::span<const double> force_demand_N) {
  constexpr const char* kContext = "identify_feedforward";
  if (reference.size() != force_demand_N.size()) {
    throw std::invalid_argument(std::string(kContext) + ": reference has " + std::to_string(reference.size()) +
                                " samples but force_demand_N has " + std::to_string(force_demand_N.size()));
  }
  if (reference.size() < 3) {
    throw std::invalid_argument(std::string(kContext) + ": need at least 3 samples, got " +
                                std::to_string(reference.size()));
  }
  for (std::size_t k = 0; k < reference.size(); ++k) {
    const ReferenceSample& r = reference[k];
    if (!std::isfinite(r.velocity_m_per_s) || !std::isfinite(r.acceleration_m_per_s2)) {
      throw std::invalid_argument(std::string(kContext) + ": reference sample " + std::to_string(k) +
                                  " is not finite (velocity " + detail::format_number(r.velocity_m_per_s) +
                                  " m/s, acceleration " + detail::format_number(r.acceleration_m_per_s2) +
                                  " m/s^2)");
    }
    if (!std::isfinite(force_demand_N[k])) {
      throw std::invalid_argument(std::string(kContext) + ": force_demand_N[" + std::to_string(k) +
                                  "] is not finite, got " + detail::format_number(force_demand_N[k]));
    }
  }

  const auto rows = static_cast<Eigen::Index>(reference.size() - 1);
  Eigen::MatrixXd regressors(rows, 3);
  Eigen::VectorXd force(rows);
  for (Eigen::Index k = 0; k < rows; ++k) {
    const ReferenceSample& now = reference[static_cast<std::size_t>(k)];
    const ReferenceSample& next = reference[static_cast<std::size_t>(k + 1)];
    regressors(k, 0) = 0.5 * (now.acceleration_m_per_s2 + next.acceleration_m_per_s2);
    regressors(k, 1) = 0.5 * (now.velocity_m_per_s + next.velocity_m_per_s);
    regressors(k, 2) = 0.5 * (detail::sign(now.velocity_m_per_s) + detail::sign(next.velocity_m_per_s));
    force(k) = force_demand_N[static_cast<std::size_t>(k)];
  }

  const Eigen::Vector3d column_norms = regressors.colwise().norm().transpose();
  if (column_norms(1) == 0.0) {
    throw std::invalid_argument(std::string(kContext) +
                                ": the reference never moves (velocity regressor is zero); m, f_v and f_c "
                                "are not identifiable");
  }
  if (column_norms(0) == 0.0) {
    throw std::invalid_argument(std::string(kContext) +
                                ": the reference never accelerates (acceleration regressor is zero); m is "
                                "not identifiable");
  }
  const Eigen::MatrixXd normalised = regressors * column_norms.cwiseInverse().asDiagonal();
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(normalised);
  // The singular values of R are those of the normalised regressors.
  const Eigen::Matrix3d r = qr.matrixR().topLeftCorner(3, 3).triangularView<Eigen::Upper>();
  const Eigen::Vector3d singular_values = Eigen::JacobiSVD<Eigen::Matrix3d>(r).singularValues();
  const double ratio = singular_values(2) / singular_values(0);
  constexpr double kMinSingularValueRatio = 1e-10;
  if (!(ratio >= kMinSingularValueRatio)) {
    throw std::invalid_argument(std::string(kContext) +
                                ": the regressors [acceleration, velocity, sign(velocity)] are rank-deficient "
                                "(sigma_min/sigma_max = " +
                                detail::format_number(ratio) + " < " + detail::format_number(kMinSingularValueRatio) +
                                "); the reference must accelerate and move at more than one speed or in both "
                                "directions");
  }
  const Eigen::Vector3d scaled = qr.solve(force);
  const Eigen::Vector3d theta = scaled.cwiseQuotient(column_norms);
  FeedforwardFit fit;
  fit.parameters = {theta(0), theta(1), theta(2)};
  fit.samples = static_cast<std::size_t>(rows);
  const Eigen::VectorXd residual = force - regressors * theta;
  fit.residual_rms_N = std::sqrt(residual.squaredNorm() / static_cast<double>(rows));
  fit.condition = 1.0 / ratio;
  // Cov(θ) = s²·(XᵀX)⁻¹ with s² = RSS/(n − 3); in the normalised columns
  // XᵀX = D·NᵀN·D, and NᵀN has the singular values of R squared.
  const double variance = rows > 3 ? residual.squaredNorm() / static_cast<double>(rows - 3) : 0.0;
  const Eigen::Matrix3d normal = normalised.transpose() * normalised;
  const Eigen::Vector3d diagonal = normal.inverse().diagonal();
  const Eigen::Vector3d error = (variance * diagonal).cwiseSqrt().cwiseQuotient(column_norms);
  fit.standard_error = {error(0), error(1), error(2)};
  return fit;
}

std::vector<std::string> unexcited_parameters(const FeedforwardFit& fit, double relative) {
  std::vector<std::string> names;
  const auto check = [&](const char* name, double value, double error) {
    if (!(error <= relative * std::abs(value))) names.emplace_back(name);
  };
  check("mass_kg", fit.parameters.mass_kg, fit.standard_error.mass_kg);
  check("viscous_N_s_per_m", fit.parameters.viscous_N_s_per_m, fit.standard_error.viscous_N_s_per_m);
  check("coulomb_N", fit.parameters.coulomb_N, fit.standard_error.coulomb_N);
  return names;
}

// ---------------------------------------------------------------------------
// Derivatives of a sampled reference

namespace {

struct QuadraticDerivatives {
  double first;   ///< derivative at the evaluation point
  double second;  ///< second derivative (constant for a quadratic)
};

/// Derivatives of the quadratic through (t[0], f[0]), (t[1], f[1]), (t[2], f[2])
/// at time `at`, written with differences to f[1] (the Lagrange weights of the
/// derivatives sum to zero) so that an offset in f does not cost precision.
QuadraticDerivatives quadratic_derivatives(const double* t, const double* f, double at) {
  const double d01 = t[0] - t[1];
  const double d02 = t[0] - t[2];
  const double d12 = t[1] - t[2];
  const double w0 = 1.0 / (d01 * d02);   // 1/((t0−t1)(t0−t2))
  const double w2 = 1.0 / (d02 * d12);   // 1/((t2−t0)(t2−t1))
  const double f0 = f[0] - f[1];
  const double f2 = f[2] - f[1];
  const double first = f0 * w0 * ((at - t[1]) + (at - t[2])) + f2 * w2 * ((at - t[0]) + (at - t[1]));
  const double second = 2.0 * (f0 * w0 + f2 * w2);
  return {first, second};
}

/// First index of the three-point stencil used at sample i of n ≥ 3.
std::size_t stencil_start(std::size_t i, std::size_t n) {
  if (i == 0) return 0;
  if (i + 1 >= n) return n - 3;
  return i - 1;
}

}  // namespace

std::vector<ReferenceSample> reference_from_positions(std::span<const double> time_s,
                                                      std::span<const double> reference_m) {
  constexpr const char* kContext = "reference_from_positions";
  if (time_s.size() != reference_m.size()) {
    throw std::invalid_argument(std::string(kContext) + ": time_s has " + std::to_string(time_s.size()) +
                                " samples but reference_m has " + std::to_string(reference_m.size()));
  }
  const std::size_t n = time_s.size();
  if (n < 3) {
    throw std::invalid_argument(std::string(kContext) + ": need at least 3 samples, got " + std::to_string(n));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(time_s[i]) || !std::isfinite(reference_m[i])) {
      throw std::invalid_argument(std::string(kContext) + ": sample " + std::to_string(i) + " is not finite (t_s " +
                                  detail::format_number(time_s[i]) + ", r_m " +
                                  detail::format_number(reference_m[i]) + ")");
    }
    if (i > 0 && !(time_s[i] > time_s[i - 1])) {
      throw std::invalid_argument(std::string(kContext) + ": time must strictly increase, but t_s[" +
                                  std::to_string(i) + "] = " + detail::format_number(time_s[i]) + " <= t_s[" +
                                  std::to_string(i - 1) + "] = " + detail::format_number(time_s[i - 1]));
    }
  }

  std::vector<ReferenceSample> reference(n);
  std::vector<double> acceleration(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t s = stencil_start(i, n);
    const QuadraticDerivatives d = quadratic_derivatives(&time_s[s], &reference_m[s], time_s[i]);
    reference[i].position_m = reference_m[i];
    reference[i].velocity_m_per_s = d.first;
    reference[i].acceleration_m_per_s2 = d.second;
    acceleration[i] = d.second;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t s = stencil_start(i, n);
    reference[i].jerk_m_per_s3 = quadratic_derivatives(&time_s[s], &acceleration[s], time_s[i]).first;
  }
  return reference;
}

// ---------------------------------------------------------------------------
// Position controller

PositionController::PositionController(const PidGains& gains, const FeedforwardParameters& feedforward,
                                       double period_s)
    : pid_(gains, period_s), feedforward_(feedforward) {
  constexpr const char* kContext = "PositionController";
  detail::require_finite(kContext, "feedforward mass_kg", feedforward.mass_kg);
  detail::require_finite(kContext, "feedforward viscous_N_s_per_m", feedforward.viscous_N_s_per_m);
  detail::require_finite(kContext, "feedforward coulomb_N", feedforward.coulomb_N);
}

double PositionController::update(const ReferenceSample& now, double measured_position_m,
                                  const ReferenceSample& ahead, const ReferenceSample& ahead_next) noexcept {
  last_error_m_ = now.position_m - measured_position_m;
  last_feedback_N_ = pid_.update(last_error_m_);
  last_feedforward_N_ = feedforward_force_N(feedforward_, ahead, ahead_next);
  return last_feedback_N_ + last_feedforward_N_;
}

void PositionController::reset() noexcept {
  pid_.reset();
  last_feedback_N_ = 0.0;
  last_feedforward_N_ = 0.0;
  last_error_m_ = 0.0;
}

}  // namespace clm::control
