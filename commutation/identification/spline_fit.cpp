#include "commutation/identification/spline_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "commutation/elementary.hpp"
#include "commutation/identification/physics_fit.hpp"

namespace clm::identification {

UniformCubicBasis spline_basis_for(const Eigen::VectorXd& position_m, double pole_pitch_m, const SplineOptions& options) {
  const double spacing = options.knot_spacing_m > 0.0 ? options.knot_spacing_m : pole_pitch_m / 8.0;
  const double low = position_m.minCoeff();
  const double high = position_m.maxCoeff();
  const int intervals = std::max(1, static_cast<int>(std::ceil((high - low) / spacing)));
  const double centre = 0.5 * (low + high);
  const double half = 0.5 * intervals * spacing;
  return {centre - half, centre + half, intervals};
}

void add_roughness_penalty(Eigen::MatrixXd& gram, int first, int n, int blocks, double weight) {
  constexpr double kSecondDifference[3] = {1.0, -2.0, 1.0};
  for (int block = 0; block < blocks; ++block) {
    const int start = first + block * n;
    for (int j = 0; j + 2 < n; ++j) {
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
          gram(start + j + r, start + j + c) += weight * kSecondDifference[r] * kSecondDifference[c];
        }
      }
    }
  }
}

namespace {

struct SplineFit {
  CoilSetModel model;
  DirectionForce direction;  ///< identified beside the model
  CoilSetModel physics;      ///< the physics-only fit the model is pulled towards
  DirectionForce physics_direction;
  RegressorQuality regressors;  ///< of the data, before the penalties
};

// One regularised linear least-squares problem per direction on `data`.
SplineFit fit_spline(const CoilSetDataset& data, double pole_pitch_m, const UniformCubicBasis& basis,
                     const SplineOptions& options) {
  const PhysicsFit physics_fit = fit_physics_only(data, pole_pitch_m, options.direction_smoothing_m_per_s);
  const CoilGain& physics_a = physics_fit.a_N_per_A;
  const CoilGain& physics_b = physics_fit.b_N_per_A;
  DirectionForce direction = direction_shape(data, options.direction_smoothing_m_per_s);
  const int n = basis.size();
  const int p = 4 + 3 * n + 1;  // [A_q, B_q, C_a (n), C_b (n), G (n), C_q of the direction-dependent force]
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(p, p);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(p, 3);
  const double inv_n = 1.0 / static_cast<double>(data.size());
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    const double y = data.position_m[t];
    const double theta = electrical_angle_rad(y, pole_pitch_m);
    const auto [s, c] = elementary::sin_cos(theta);
    const double ia = data.currents_A(0, t), ib = data.currents_A(1, t);
    const auto span = basis.evaluate(y);
    int index[17];
    double value[17];
    const double head[4] = {c * ia, c * ib, s * ia, s * ib};
    for (int k = 0; k < 4; ++k) {
      index[k] = k;
      value[k] = head[k];
      index[4 + k] = 4 + span.first + k;
      value[4 + k] = span.value[static_cast<std::size_t>(k)] * ia;
      index[8 + k] = 4 + n + span.first + k;
      value[8 + k] = span.value[static_cast<std::size_t>(k)] * ib;
      index[12 + k] = 4 + 2 * n + span.first + k;
      value[12 + k] = span.value[static_cast<std::size_t>(k)];
    }
    index[16] = p - 1;
    value[16] = direction.identified() ? direction.feature(data.velocity_m_per_s[t]) : 0.0;
    for (int r = 0; r < 17; ++r) {
      for (int k = 0; k < 17; ++k) gram(index[r], index[k]) += inv_n * value[r] * value[k];
      for (int q = 0; q < 3; ++q) rhs(index[r], q) += inv_n * value[r] * data.wrench(q, t);
    }
  }
  // The data alone: each spline function's coefficients judged together,
  // the direction-dependent force's column only when it is identified.
  const int columns = direction.identified() ? p : p - 1;
  // The first and the last function of each are centred a knot beyond the
  // data's range (spline_basis_for): never counted as unexcited.
  std::vector<ColumnGroup> groups{{0, 1}, {1, 1}, {2, 1}, {3, 1}};
  for (int first = 4; first < 4 + 3 * n; first += n) {
    groups.push_back({first, 1, false});
    groups.push_back({first + 1, n - 2});
    groups.push_back({first + n - 1, 1, false});
  }
  if (direction.identified()) groups.push_back({p - 1, 1});
  const RegressorQuality regressors = regressor_quality(gram.topLeftCorner(columns, columns), groups);
  add_roughness_penalty(gram, 4, n, 3, options.smoothing);
  const double lambda2 = options.regularisation * options.regularisation;
  for (int k = 0; k < 4; ++k) gram(k, k) += lambda2;
  for (int q = 0; q < 3; ++q) rhs.block<4, 1>(0, q) += lambda2 * physics_target(physics_a, physics_b, q);
  // A tiny ridge keeps knots without data and an absent direction term defined.
  for (int k = 4; k < p; ++k) gram(k, k) += 1e-12 * (1.0 + gram(k, k));
  const Eigen::MatrixXd solution = gram.ldlt().solve(rhs);
  if (!solution.allFinite()) throw std::invalid_argument("spline least-squares problem is singular");

  SplineFit fit;
  CoilSetModel& result = fit.model;
  result.column_a_spline.resize(3, n);
  result.column_b_spline.resize(3, n);
  result.cogging_spline.resize(3, n);
  for (int q = 0; q < 3; ++q) {
    result.a_N_per_A(q, 0) = solution(0, q);
    result.a_N_per_A(q, 1) = solution(1, q);
    result.b_N_per_A(q, 0) = solution(2, q);
    result.b_N_per_A(q, 1) = solution(3, q);
    for (int j = 0; j < n; ++j) {
      result.column_a_spline(q, j) = solution(4 + j, q);
      result.column_b_spline(q, j) = solution(4 + n + j, q);
      result.cogging_spline(q, j) = solution(4 + 2 * n + j, q);
    }
    direction.amplitude[q] = direction.identified() ? solution(p - 1, q) : 0.0;
  }
  fit.direction = direction;
  fit.physics_direction = physics_fit.direction;
  fit.regressors = regressors;
  CoilSetModel& physics = fit.physics;
  physics.a_N_per_A = physics_a;
  physics.b_N_per_A = physics_b;
  physics.column_a_spline = SplineCoefficients::Zero(3, n);
  physics.column_b_spline = SplineCoefficients::Zero(3, n);
  // The uniform B-splines sum to one: a constant force is every coefficient.
  physics.cogging_spline = physics_fit.constant * Eigen::RowVectorXd::Ones(n);
  return fit;
}

}  // namespace

CoilSetModel identify_spline_coil_set(const CoilSetDataset& training, const CoilSetDataset& validation,
                                      double pole_pitch_m, const UniformCubicBasis& basis,
                                      const SplineOptions& options, IdentificationReport& report) {
  check_dataset(training, "training");
  if (!(options.smoothing >= 0.0) || !(options.regularisation >= 0.0)) {
    throw std::invalid_argument("spline smoothing and regularisation must be non-negative");
  }
  const auto as_model = [&](const CoilSetModel& part) {
    return single_coil_set_model(ModelKind::kSpline, pole_pitch_m, {}, basis, part);
  };
  // Fit on the training data alone for the held-out estimate; the model put
  // to use is fit on every sample, as the PGNN's is.
  SplineFit fit = fit_spline(training, pole_pitch_m, basis, options);
  fill_report_costs({as_model(fit.model), fit.direction}, {as_model(fit.physics), fit.physics_direction}, training,
                    validation, report);
  report.refit_on_all_data = validation.size() > 0;
  CoilSetDataset all;
  if (report.refit_on_all_data) all = joined(training, validation);
  const CoilSetDataset& fitted = report.refit_on_all_data ? all : training;
  if (report.refit_on_all_data) fit = fit_spline(fitted, pole_pitch_m, basis, options);
  fill_fit_costs({as_model(fit.model), fit.direction}, {as_model(fit.physics), fit.physics_direction}, fitted, report);
  report.regularised_cost = report.model_fit.sum();
  report.regressors = fit.regressors;
  report.excitation_gaps = excitation_gaps(fitted, pole_pitch_m);
  report.best_restart = 0;
  report.iterations = 0;
  return fit.model;
}

}  // namespace clm::identification
