#include "commutation/identification/pgnn_training.hpp"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "commutation/identification/linear_parameters.hpp"
#include "commutation/identification/physics_fit.hpp"
#include "commutation/identification/sample_sums.hpp"

namespace clm::identification {
namespace {

// Residuals sqrt(2/N)·(F_q − F̂_q) of a chunk of samples in one direction,
// with the analytic Jacobian.
class ChunkCost final : public ceres::CostFunction {
 public:
  ChunkCost(const CoilSetDataset& data, const PgnnFeatures& features, const PgnnLayout& layout, int direction,
            Eigen::Index begin, Eigen::Index end, double scale)
      : data_(data), features_(features), layout_(layout), direction_(direction), begin_(begin), end_(end),
        scale_(scale) {
    set_num_residuals(static_cast<int>(end - begin));
    mutable_parameter_block_sizes()->push_back(layout.linear_size());
    mutable_parameter_block_sizes()->push_back(layout.nonlinear_size());
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* linear = parameters[0];
    const double* nonlinear = parameters[1];
    const int p = layout_.linear_size();
    const int q = layout_.nonlinear_size();
    const int na = layout_.column_hidden;
    const int nc = layout_.cogging_hidden;
    double m[kMaxRegressor];
    double ha[Network::kMaxWidth], hb[Network::kMaxWidth], hc[Network::kMaxWidth];
    for (Eigen::Index t = begin_; t < end_; ++t) {
      const int row = static_cast<int>(t - begin_);
      const double x = features_.input[t];
      const double ia = data_.currents_A(0, t);
      const double ib = data_.currents_A(1, t);
      regressor(layout_, nonlinear, features_.cos_theta[t], features_.sin_theta[t], x, features_.direction[t], ia, ib, m,
                ha, hb, hc);
      double prediction = 0.0;
      for (int k = 0; k < p; ++k) prediction += linear[k] * m[k];
      residuals[row] = scale_ * (data_.wrench(direction_, t) - prediction);
      if (jacobians == nullptr) continue;
      if (jacobians[0] != nullptr) {
        double* j = jacobians[0] + row * p;
        for (int k = 0; k < p; ++k) j[k] = -scale_ * m[k];
      }
      if (jacobians[1] != nullptr) {
        double* j = jacobians[1] + row * q;
        // ∂F̂/∂(w, b) of a hidden neuron = output weight · (1 − h²) · (x, 1) · multiplier.
        const auto fill = [&](int first, const double* h, int width, int output_offset, double multiplier) {
          for (int n = 0; n < width; ++n) {
            const double g = -scale_ * linear[output_offset + n] * (1.0 - h[n] * h[n]) * multiplier;
            j[first + n] = g * x;
            j[first + width + n] = g;
          }
        };
        fill(0, ha, na, layout_.column_a_offset(), ia);
        fill(2 * na, hb, na, layout_.column_b_offset(), ib);
        fill(4 * na, hc, nc, layout_.cogging_offset(), 1.0);
      }
    }
    return true;
  }

 private:
  const CoilSetDataset& data_;
  const PgnnFeatures& features_;
  PgnnLayout layout_;
  int direction_;
  Eigen::Index begin_, end_;
  double scale_;
};

// sqrt(2)·λ·(θ_phy,q − θ*_phy,q): the regularisation term of eq. (26).
class PhysicsPrior final : public ceres::CostFunction {
 public:
  PhysicsPrior(const PgnnLayout& layout, const Eigen::Vector4d& target, double weight)
      : target_(target), weight_(weight) {
    set_num_residuals(4);
    mutable_parameter_block_sizes()->push_back(layout.linear_size());
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int p = parameter_block_sizes()[0];
    for (int k = 0; k < 4; ++k) residuals[k] = weight_ * (parameters[0][k] - target_[k]);
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      std::fill(jacobians[0], jacobians[0] + 4 * p, 0.0);
      for (int k = 0; k < 4; ++k) jacobians[0][k * p + k] = weight_;
    }
    return true;
  }

 private:
  Eigen::Vector4d target_;
  double weight_;
};

// The tolerances both PGNN solvers stop at (Ceres' names and meanings).
constexpr double kFunctionTolerance = 1e-10;   // relative decrease of the cost
constexpr double kGradientTolerance = 1e-12;   // largest entry of the gradient
constexpr double kParameterTolerance = 1e-10;  // step relative to the parameters
// The variable-projection solve also stops when the last kStallIterations
// iterations lowered the cost (26) by less than kStallTolerance of it. The
// cost is a mean square over N ≥ 1000 samples of noisy force; its sampling
// error is about sqrt(2/N) ≥ 1e-3 of it at best, so a change 10× below that
// is one no held-out comparison can see, and the iterations that chase it
// (the slow tail of Levenberg–Marquardt) cost most of the time
// (docs/design-decisions.md, "PGNN solver").
constexpr int kStallIterations = 10;
constexpr double kStallTolerance = 1e-4;

// Levenberg–Marquardt in Ceres with those tolerances (the joint Schur
// solve); the caller chooses the linear solver.
ceres::Solver::Options levenberg_marquardt_options(int max_iterations, int threads) {
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = max_iterations;
  options.num_threads = threads;
  options.function_tolerance = kFunctionTolerance;
  options.gradient_tolerance = kGradientTolerance;
  options.parameter_tolerance = kParameterTolerance;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  return options;
}

// Solves and adds the iterations taken to `iterations`.
ceres::Solver::Summary solve_counting(const ceres::Solver::Options& options, ceres::Problem& problem,
                                      int& iterations) {
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  iterations += static_cast<int>(summary.iterations.size());
  return summary;
}

// Levenberg–Marquardt on all parameters of eq. (26); returns the final cost
// (eq. 26) and adds the iterations taken.
double levenberg_marquardt(const CoilSetDataset& data, const PgnnFeatures& f, const PgnnLayout& layout,
                           const CoilGain& physics_a, const CoilGain& physics_b, double regularisation,
                           int max_iterations, int threads, std::vector<double>& nonlinear,
                           Eigen::Matrix<double, Eigen::Dynamic, 3>& linear, int& iterations) {
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  std::array<std::vector<double>, 3> direction_parameters;
  for (int q = 0; q < 3; ++q) {
    direction_parameters[static_cast<std::size_t>(q)].assign(linear.col(q).data(), linear.col(q).data() + linear.rows());
  }
  const double scale = std::sqrt(2.0 / static_cast<double>(data.size()));
  constexpr Eigen::Index kChunk = 256;
  auto* ordering = new ceres::ParameterBlockOrdering;
  for (int q = 0; q < 3; ++q) {
    double* block = direction_parameters[static_cast<std::size_t>(q)].data();
    for (Eigen::Index begin = 0; begin < data.size(); begin += kChunk) {
      const Eigen::Index end = std::min(data.size(), begin + kChunk);
      problem.AddResidualBlock(new ChunkCost(data, f, layout, q, begin, end, scale), nullptr, block, nonlinear.data());
    }
    problem.AddResidualBlock(new PhysicsPrior(layout, physics_target(physics_a, physics_b, q),
                                              std::sqrt(2.0) * regularisation),
                             nullptr, block);
    ordering->AddElementToGroup(block, 0);  // eliminated by the Schur complement
  }
  ordering->AddElementToGroup(nonlinear.data(), 1);

  ceres::Solver::Options options = levenberg_marquardt_options(max_iterations, threads);
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.linear_solver_ordering.reset(ordering);
  const ceres::Solver::Summary summary = solve_counting(options, problem, iterations);
  for (int q = 0; q < 3; ++q) {
    linear.col(q) = Eigen::Map<const Eigen::VectorXd>(direction_parameters[static_cast<std::size_t>(q)].data(), linear.rows());
  }
  return summary.final_cost;
}

// Variable projection (Golub–Pereyra, Kaufman's Jacobian): the PGNN is
// linear in θ_L (eq. 29), so for given hidden layers θ_NL the best θ_L of
// eq. (26) is the ridge solution of eq. (31), and only θ_NL is left to the
// Levenberg–Marquardt solver. The residuals are those of eq. (26) at
// θ_L(θ_NL), direction-major, then the 4 prior residuals of each direction:
//   r = [sqrt(2/N)·(F_q − M θ_L,q) ; sqrt(2)·λ·(θ_phy,q − θ*_phy,q)],
// so the cost ½‖r‖² is eq. (26) exactly. With A = ∂r/∂θ_L (the same M for
// all three directions) and V_q = ∂r_q/∂θ_NL at fixed θ_L, Kaufman's
// Jacobian is J_q = (I − A (AᵀA)⁻¹ Aᵀ) V_q: the change of θ_L with θ_NL
// projected out, without the second-order term in the residual.
//
// The solver needs only JᵀJ and Jᵀr, and the Jacobian has a structure that
// gives them without forming it: V_q = −scale·P·diag(w_q), P the derivatives
// of the hidden outputs (times their multiplier) and w_q the output weight of
// each neuron in direction q, so with Z = (MᵀM/N + Λ)⁻¹·MᵀP/N (Λ the ridge
// of eq. 31; the same for all directions) J_q = scale·R·diag(w_q) on the data rows, R = M Z − P, and
// −sqrt(2)·λ·Z[0:4]·diag(w_q) on the prior rows. Hence
//   JᵀJ = (scale²·RᵀR + 2λ²·Z[0:4]ᵀZ[0:4]) ∘ Σ_q w_q w_qᵀ,
//   Jᵀr = Σ_q w_q ∘ (scale·Rᵀ r_q − sqrt(2)·λ·Z[0:4]ᵀ r_prior,q):
// one n×q² sum for the three directions instead of three, and no 3n×q
// Jacobian (docs/design-decisions.md, "PGNN solver").
class ProjectedCost final {
 public:
  ProjectedCost(const CoilSetDataset& data, const PgnnFeatures& features, const PgnnLayout& layout,
                const CoilGain& physics_a, const CoilGain& physics_b, double regularisation)
      : data_(data), features_(features), layout_(layout), physics_a_(physics_a), physics_b_(physics_b),
        regularisation_(regularisation) {}

  int num_residuals() const { return static_cast<int>(3 * data_.size() + 12); }
  int num_parameters() const { return layout_.nonlinear_size(); }

  // Residuals r at θ_NL = `nonlinear` into `residuals` (num_residuals());
  // returns the cost ½‖r‖². Keeps what normal_equations needs at that θ_NL.
  double evaluate(const double* nonlinear, Eigen::VectorXd& residuals) const {
    const Eigen::Index n = data_.size();
    const int p = layout_.linear_size();
    const int q = layout_.nonlinear_size();
    const int na = layout_.column_hidden;
    const int nc = layout_.cogging_hidden;
    const int width = p + 3 + q;
    // One row per sample: the regressor M (p), the wrench (3), then the
    // derivatives P of the hidden outputs (q).
    samples_.resize(n, width);
    double ha[Network::kMaxWidth], hb[Network::kMaxWidth], hc[Network::kMaxWidth];
    for (Eigen::Index t = 0; t < n; ++t) {
      double* row = samples_.row(t).data();
      const double x = features_.input[t];
      const double ia = data_.currents_A(0, t);
      const double ib = data_.currents_A(1, t);
      regressor(layout_, nonlinear, features_.cos_theta[t], features_.sin_theta[t], x, features_.direction[t], ia, ib,
                row, ha, hb, hc);
      for (int d = 0; d < 3; ++d) row[p + d] = data_.wrench(d, t);
      double* derivatives = row + p + 3;
      const auto fill = [&](int first, const double* h, int width_h, double multiplier) {
        for (int j = 0; j < width_h; ++j) {
          const double g = (1.0 - h[j] * h[j]) * multiplier;
          derivatives[first + j] = g * x;
          derivatives[first + width_h + j] = g;
        }
      };
      fill(0, ha, na, ia);
      fill(2 * na, hb, na, ib);
      fill(4 * na, hc, nc, 1.0);
    }
    // θ_L by eq. (31) (the normal equations of r over θ_L, halved), from
    // the rows of [M F] in the samples' Gram matrix.
    sums_.setZero(width, width);
    add_lower_gram(samples_, 0, p + 3, sums_);
    const double inv_n = 1.0 / static_cast<double>(n);
    Eigen::MatrixXd gram = sums_.topLeftCorner(p, p).selfadjointView<Eigen::Lower>();
    gram *= inv_n;
    Eigen::MatrixXd rhs = sums_.block(p, 0, 3, p).transpose() * inv_n;
    const double lambda2 = regularisation_ * regularisation_;
    Eigen::Matrix<double, 4, 3> target;
    for (int d = 0; d < 3; ++d) target.col(d) = physics_target(physics_a_, physics_b_, d);
    for (int k = 0; k < 4; ++k) gram(k, k) += lambda2;
    rhs.topRows<4>() += lambda2 * target;
    ridge_.resize(p);
    for (int k = 0; k < 4; ++k) ridge_[k] = lambda2;
    for (int k = 4; k < p; ++k) {
      ridge_[k] = 1e-10 * (1.0 + gram(k, k));
      gram(k, k) += ridge_[k];
    }
    solver_.compute(gram);
    linear_ = solver_.solve(rhs);  // p × 3
    const Eigen::MatrixXd& linear = linear_;

    const double scale = std::sqrt(2.0 * inv_n);
    const double prior_weight = std::sqrt(2.0) * regularisation_;
    residuals.resize(num_residuals());
    // F − M θ_L sample by sample, each a sum in parameter order.
    for (Eigen::Index t = 0; t < n; ++t) {
      const double* row = samples_.row(t).data();
      for (int d = 0; d < 3; ++d) {
        double prediction = 0.0;
        for (int k = 0; k < p; ++k) prediction += row[k] * linear(k, d);
        residuals[d * n + t] = scale * (row[p + d] - prediction);
      }
    }
    for (int d = 0; d < 3; ++d) {
      for (int k = 0; k < 4; ++k) residuals[3 * n + 4 * d + k] = prior_weight * (linear(k, d) - target(k, d));
    }
    return 0.5 * residuals.squaredNorm();
  }

  // JᵀJ into `normal` and Jᵀr into `gradient` at the θ_NL of the last
  // evaluate(), whose residuals `residuals` are.
  void normal_equations(const Eigen::VectorXd& residuals, Eigen::MatrixXd& normal, Eigen::VectorXd& gradient) const {
    const Eigen::Index n = data_.size();
    const int q = layout_.nonlinear_size();
    const int na = layout_.column_hidden;
    const int nc = layout_.cogging_hidden;
    const double inv_n = 1.0 / static_cast<double>(n);
    const double scale = std::sqrt(2.0 * inv_n);
    const double prior_weight = std::sqrt(2.0) * regularisation_;
    const Eigen::MatrixXd& linear = linear_;
    const Eigen::Map<const Eigen::MatrixXd> data_residuals(residuals.data(), n, 3);
    // C = MᵀP/n and Z = gram⁻¹·C (gram = MᵀM/n + Λ, Λ the ridge of eq. 31).
    // Since gram·Z = C, RᵀR/n = PᵀP/n − CᵀZ − ZᵀΛZ: the Schur complement of
    // [MᵀM MᵀP; PᵀM PᵀP]/n, from the samples' Gram matrix, without forming
    // R (n×p×q operations fewer per Jacobian).
    const int p = layout_.linear_size();
    const int first = p + 3;  // the derivatives' rows of the samples' Gram matrix
    sums_.bottomRows(q).setZero();
    add_lower_gram(samples_, first, first + q, sums_);
    const Eigen::MatrixXd cross = sums_.block(first, 0, q, p).transpose() * inv_n;  // p × q
    const Eigen::MatrixXd z = solver_.solve(cross);                               // p × q
    Eigen::MatrixXd projected_gram = sums_.bottomRightCorner(q, q).selfadjointView<Eigen::Lower>();
    projected_gram *= inv_n;
    projected_gram.noalias() -= cross.transpose() * z;
    const Eigen::MatrixXd ridge_rows = ridge_.cwiseSqrt().asDiagonal() * z;
    projected_gram.noalias() -= ridge_rows.transpose() * ridge_rows;
    projected_gram = 0.5 * (projected_gram + projected_gram.transpose()).eval();
    // Rᵀr = Zᵀ(Mᵀr) − Pᵀr on the (scaled) data residuals.
    Eigen::MatrixXd products = Eigen::MatrixXd::Zero(samples_.cols(), 3);  // [M F P]ᵀ r
    add_transposed_product(samples_, data_residuals, products);
    Eigen::MatrixXd projected_rhs = z.transpose() * products.topRows(p);
    projected_rhs -= products.bottomRows(q);
    const Eigen::MatrixXd prior_rows = z.topRows<4>();
    Eigen::MatrixXd prior_gram = Eigen::MatrixXd::Zero(q, q);
    prior_gram.selfadjointView<Eigen::Lower>().rankUpdate(prior_rows.transpose());
    prior_gram = prior_gram.selfadjointView<Eigen::Lower>();
    // The output weight of each hidden neuron's two parameters, per direction.
    Eigen::MatrixXd weights(q, 3);
    for (int d = 0; d < 3; ++d) {
      for (int j = 0; j < na; ++j) {
        weights(j, d) = weights(na + j, d) = linear(layout_.column_a_offset() + j, d);
        weights(2 * na + j, d) = weights(3 * na + j, d) = linear(layout_.column_b_offset() + j, d);
      }
      for (int j = 0; j < nc; ++j) weights(4 * na + j, d) = weights(4 * na + nc + j, d) = linear(layout_.cogging_offset() + j, d);
    }
    const Eigen::MatrixXd outer = weights * weights.transpose();  // Σ_q w_q w_qᵀ
    normal = (2.0 * projected_gram + prior_weight * prior_weight * prior_gram).cwiseProduct(outer);
    gradient.setZero(q);
    for (int d = 0; d < 3; ++d) {
      const Eigen::Vector4d prior_residuals = residuals.segment<4>(3 * n + 4 * d);
      gradient += weights.col(d).cwiseProduct(scale * projected_rhs.col(d) -
                                               prior_weight * (prior_rows.transpose() * prior_residuals));
    }
  }

 private:
  const CoilSetDataset& data_;
  const PgnnFeatures& features_;
  PgnnLayout layout_;
  CoilGain physics_a_, physics_b_;
  double regularisation_;
  // Work space, sized at the first evaluation (one solve, one thread).
  mutable SampleRows samples_;  // per sample: M, the wrench, P
  mutable SampleRows sums_;     // their Gram matrix, lower triangle
  mutable Eigen::MatrixXd linear_;
  mutable Eigen::VectorXd ridge_;  // what eq. (31) adds to the diagonal of MᵀM/n
  mutable Eigen::LDLT<Eigen::MatrixXd> solver_;
};

// Levenberg–Marquardt on θ_NL of the variable-projection problem, with the
// rules of Ceres' LEVENBERG_MARQUARDT trust region (Marquardt's diagonal,
// the radius update of Nielsen, and the tolerances above), written here so that JᵀJ and Jᵀr are sums
// over samples in one order on every CPU (sample_sums.hpp): Ceres forms them
// with products whose order follows the CPU. Returns the final cost (eq. 26) and adds the
// iterations (the first evaluation counts as one, as in Ceres' summary).
double minimise_projected(const ProjectedCost& cost_function, int max_iterations, std::vector<double>& x,
                          int& iterations) {
  const int q = static_cast<int>(x.size());
  Eigen::VectorXd residuals, trial_residuals;
  Eigen::MatrixXd normal;
  Eigen::VectorXd gradient;  // Jᵀr
  double cost = cost_function.evaluate(x.data(), residuals);
  cost_function.normal_equations(residuals, normal, gradient);
  ++iterations;
  double radius = 1e4;  // Ceres' initial_trust_region_radius
  double decrease_factor = 2.0;
  std::vector<double> trial(x.size());
  std::vector<double> history;  // the cost at the start of each iteration
  history.reserve(static_cast<std::size_t>(std::max(0, max_iterations)));
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    if (gradient.lpNorm<Eigen::Infinity>() <= kGradientTolerance) break;
    history.push_back(cost);
    if (iteration >= kStallIterations &&
        history[static_cast<std::size_t>(iteration - kStallIterations)] - cost <= kStallTolerance * cost) {
      break;
    }
    // (JᵀJ + D/radius)·δ = −Jᵀr with D = diag(JᵀJ) clamped to [1e-6, 1e32].
    Eigen::MatrixXd damped = normal;
    for (int k = 0; k < q; ++k) damped(k, k) += std::clamp(normal(k, k), 1e-6, 1e32) / radius;
    const Eigen::LLT<Eigen::MatrixXd> factor(damped);
    Eigen::VectorXd step;
    bool valid = factor.info() == Eigen::Success;
    if (valid) {
      step = factor.solve(-gradient);
      valid = step.allFinite();
    }
    ++iterations;
    double trial_cost = std::numeric_limits<double>::infinity();
    double predicted = 0.0;
    if (valid) {
      Eigen::Map<const Eigen::VectorXd> current(x.data(), q);
      const double step_norm = step.norm();
      if (step_norm <= kParameterTolerance * (current.norm() + kParameterTolerance)) break;
      for (int k = 0; k < q; ++k) trial[static_cast<std::size_t>(k)] = x[static_cast<std::size_t>(k)] + step[k];
      trial_cost = cost_function.evaluate(trial.data(), trial_residuals);
      // Decrease the linear model predicts: −(Jᵀr·δ + ½ δᵀJᵀJδ).
      predicted = -(gradient.dot(step) + 0.5 * step.dot(normal * step));
    }
    const double ratio = predicted > 0.0 ? (cost - trial_cost) / predicted : -1.0;
    if (!(ratio > 1e-3)) {  // rejected: shrink the region
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < 1e-32) break;  // min_trust_region_radius
      continue;
    }
    const double change = cost - trial_cost;
    // The last evaluation was at the trial point: its regressors serve.
    x = trial;
    cost = trial_cost;
    residuals.swap(trial_residuals);
    cost_function.normal_equations(residuals, normal, gradient);
    const double excess = 2.0 * ratio - 1.0;
    radius = std::min(1e16, radius / std::max(1.0 / 3.0, 1.0 - excess * excess * excess));
    decrease_factor = 2.0;
    if (change <= kFunctionTolerance * cost) break;
  }
  return cost;
}

// Levenberg–Marquardt on θ_NL of the variable-projection problem; θ_L by
// eq. (31) afterwards. Returns the final cost (eq. 26) and adds the iterations.
double variable_projection(const CoilSetDataset& data, const PgnnFeatures& f, const PgnnLayout& layout,
                           const CoilGain& physics_a, const CoilGain& physics_b, double regularisation,
                           int max_iterations, int /*threads: the solve is one thread*/, std::vector<double>& nonlinear,
                           Eigen::Matrix<double, Eigen::Dynamic, 3>& linear, int& iterations) {
  const ProjectedCost cost(data, f, layout, physics_a, physics_b, regularisation);
  const double final_cost = minimise_projected(cost, max_iterations, nonlinear, iterations);
  ridge_linear(data, f, layout, nonlinear.data(), physics_a, physics_b, regularisation, linear);
  return final_cost;
}

// The physics-only fit as a PGNN of `layout` whose networks are zero but
// for the cogging network's output bias, the fit's constant force.
CoilSetModel physics_coil_set(const PhysicsFit& fit, const PgnnLayout& layout) {
  CoilSetModel physics;
  physics.a_N_per_A = fit.a_N_per_A;
  physics.b_N_per_A = fit.b_N_per_A;
  physics.column_a = Network::zeros({layout.column_hidden});
  physics.column_b = Network::zeros({layout.column_hidden});
  physics.cogging = Network::zeros({layout.cogging_hidden});
  physics.cogging.layers[1].biases = fit.constant;
  physics.gain_harmonics_N_per_A = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, layout.gain_harmonic_count());
  physics.cogging_harmonics_N = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, layout.cogging_harmonic_count());
  return physics;
}

CoilSetDataset decimate(const CoilSetDataset& data, int every) {
  std::vector<Eigen::Index> indices;
  for (Eigen::Index i = 0; i < data.size(); i += std::max(1, every)) indices.push_back(i);
  return data.subset(indices);
}

}  // namespace

CoilSetModel identify_pgnn_coil_set(const CoilSetDataset& training, const CoilSetDataset& validation,
                                    double pole_pitch_m, const PositionNormalisation& normalisation,
                                    const PgnnOptions& options, IdentificationReport& report,
                                    const std::function<void(const PgnnProgress&)>& progress) {
  check_dataset(training, "training");
  if (options.column_hidden < 1 || options.column_hidden > Network::kMaxWidth || options.cogging_hidden < 1 ||
      options.cogging_hidden > Network::kMaxWidth) {
    throw std::invalid_argument("network sizes must lie in 1.." + std::to_string(Network::kMaxWidth));
  }
  if (options.restarts < 1) throw std::invalid_argument("at least one restart is needed");
  if (!(options.regularisation >= 0.0)) throw std::invalid_argument("regularisation must be non-negative");
  if (!(options.direction_smoothing_m_per_s >= 0.0)) {
    throw std::invalid_argument("direction smoothing velocity must be non-negative");
  }

  const PhysicsFit physics_fit = fit_physics_only(training, pole_pitch_m, options.direction_smoothing_m_per_s);
  const CoilGain& physics_a = physics_fit.a_N_per_A;
  const CoilGain& physics_b = physics_fit.b_N_per_A;
  // The shape of the direction-dependent force fitted beside the model; its
  // amplitude comes out of eq. (31) with the other linear parameters.
  const DirectionForce shape = direction_shape(training, options.direction_smoothing_m_per_s);
  const PgnnLayout layout{options.column_hidden, options.cogging_hidden, options.harmonics};
  const auto solve = options.solver == PgnnSolver::kVariableProjection ? variable_projection : levenberg_marquardt;
  const bool held_out = validation.size() > 0;
  // The model of parameters (θ_NL, θ_L) as ElectromagneticModel evaluates it,
  // and the direction-dependent force identified beside it.
  struct Candidate {
    ElectromagneticModel model;
    DirectionForce direction;
  };
  const auto model_of = [&](const std::vector<double>& nonlinear, const Eigen::Matrix<double, Eigen::Dynamic, 3>& linear) {
    CoilSetModel part;
    DirectionForce direction = shape;
    unpack_parameters(layout, nonlinear.data(), linear, part, direction);
    return Candidate{single_coil_set_model(ModelKind::kPgnn, pole_pitch_m, normalisation, {}, part, layout.harmonics),
                     direction};
  };

  const CoilSetDataset coarse = decimate(training, options.restart_decimation);
  const PgnnFeatures coarse_features = features_of(coarse, pole_pitch_m, normalisation, shape);
  const CoilSetDataset polish = decimate(training, options.final_decimation);
  const PgnnFeatures polish_features = features_of(polish, pole_pitch_m, normalisation, shape);
  const PgnnFeatures full_features = features_of(training, pole_pitch_m, normalisation, shape);

  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> slope(-4.0, 4.0);
  std::uniform_real_distribution<double> centre(-1.0, 1.0);
  double best_score = std::numeric_limits<double>::infinity();
  std::vector<double> best_nonlinear;
  Eigen::Matrix<double, Eigen::Dynamic, 3> best_linear;
  report.iterations = 0;
  for (int restart = 0; restart < options.restarts; ++restart) {
    // Hidden neurons with random slopes and centres spread over the stroke
    // (inputs are normalised to [−1, 1]); output layers by eq. (31), as the
    // paper initialises them.
    std::vector<double> nonlinear(static_cast<std::size_t>(layout.nonlinear_size()));
    const auto init = [&](int first, int width) {
      for (int n = 0; n < width; ++n) {
        const double w = slope(rng);
        nonlinear[static_cast<std::size_t>(first + n)] = w;
        nonlinear[static_cast<std::size_t>(first + width + n)] = -w * centre(rng);
      }
    };
    init(0, layout.column_hidden);
    init(2 * layout.column_hidden, layout.column_hidden);
    init(4 * layout.column_hidden, layout.cogging_hidden);
    Eigen::Matrix<double, Eigen::Dynamic, 3> linear;
    ridge_linear(coarse, coarse_features, layout, nonlinear.data(), physics_a, physics_b, options.regularisation,
                 linear);
    const double cost = solve(coarse, coarse_features, layout, physics_a, physics_b, options.regularisation,
                              options.restart_iterations, options.threads, nonlinear, linear, report.iterations);
    // With held-out data the restart that predicts them best is kept: a low
    // training cost alone also rewards networks that swing wildly between
    // the training blocks (docs/commutation.md, "Identification").
    double score = cost;
    if (held_out) {
      const Candidate candidate = model_of(nonlinear, linear);
      score = coil_set_cost(candidate.model, 0, validation, candidate.direction).sum();
    }
    if (score < best_score) {
      best_score = score;
      best_nonlinear = nonlinear;
      best_linear = linear;
      report.best_restart = restart;
    }
    if (progress) progress({restart, options.restarts, cost});
  }

  const double final_cost = solve(polish, polish_features, layout, physics_a, physics_b, options.regularisation,
                                  options.final_iterations, options.threads, best_nonlinear, best_linear,
                                  report.iterations);
  // Eq. (31) last: the model can then never fit worse than the physics-only one.
  ridge_linear(training, full_features, layout, best_nonlinear.data(), physics_a, physics_b, options.regularisation,
               best_linear);
  if (progress) progress({options.restarts, options.restarts, final_cost});

  const auto physics_model =
      single_coil_set_model(ModelKind::kPgnn, pole_pitch_m, normalisation, {}, physics_coil_set(physics_fit, layout),
                            layout.harmonics);
  // Training and validation costs are those of the model fit without the
  // validation blocks: the held-out estimate of how it predicts.
  const Candidate trained = model_of(best_nonlinear, best_linear);
  fill_report_costs({trained.model, trained.direction}, {physics_model, physics_fit.direction}, training, validation,
                    report);
  CoilSetModel result;
  DirectionForce direction = shape;
  unpack_parameters(layout, best_nonlinear.data(), best_linear, result, direction);
  static const CoilSetDataset kNone;
  return refit_pgnn_coil_set(result, direction, training, options.refit_on_all_data ? validation : kNone, pole_pitch_m,
                             normalisation, options, report);
}

CoilSetModel refit_pgnn_coil_set(const CoilSetModel& trained, const DirectionForce& trained_direction,
                                 const CoilSetDataset& training, const CoilSetDataset& validation, double pole_pitch_m,
                                 const PositionNormalisation& normalisation, const PgnnOptions& options,
                                 IdentificationReport& report) {
  const PgnnLayout layout = PgnnLayout::of(trained, options.harmonics);
  const auto solve = options.solver == PgnnSolver::kVariableProjection ? variable_projection : levenberg_marquardt;
  std::vector<double> nonlinear;
  Eigen::Matrix<double, Eigen::Dynamic, 3> linear;
  pack_parameters(layout, trained, trained_direction, nonlinear, linear);
  // The model put to use has seen every sample: with held-out data, the
  // chosen parameters are polished once more on training and validation
  // together, so that no stretch of the stroke is left to extrapolation.
  const bool held_out = validation.size() > 0;
  CoilSetDataset all;
  if (held_out) all = joined(training, validation);
  const CoilSetDataset& fitted = held_out ? all : training;
  const PhysicsFit physics_fit = fit_physics_only(fitted, pole_pitch_m, options.direction_smoothing_m_per_s);
  const CoilGain& physics_a = physics_fit.a_N_per_A;
  const CoilGain& physics_b = physics_fit.b_N_per_A;
  const DirectionForce shape = trained_direction;
  if (held_out) {
    const CoilSetDataset all_polish = decimate(all, options.final_decimation);
    solve(all_polish, features_of(all_polish, pole_pitch_m, normalisation, shape), layout, physics_a, physics_b,
          options.regularisation, options.final_iterations, options.threads, nonlinear, linear, report.iterations);
    ridge_linear(all, features_of(all, pole_pitch_m, normalisation, shape), layout, nonlinear.data(), physics_a,
                 physics_b, options.regularisation, linear);
  }
  report.refit_on_all_data = held_out;
  CoilSetModel result;
  DirectionForce direction = shape;
  unpack_parameters(layout, nonlinear.data(), linear, result, direction);
  fill_fit_costs({single_coil_set_model(ModelKind::kPgnn, pole_pitch_m, normalisation, {}, result, layout.harmonics),
                  direction},
                 {single_coil_set_model(ModelKind::kPgnn, pole_pitch_m, normalisation, {},
                                        physics_coil_set(physics_fit, layout), layout.harmonics),
                  physics_fit.direction},
                 fitted, report);
  double prior = 0.0;
  for (int q = 0; q < 3; ++q) {
    const Eigen::Vector4d deviation =
        physics_target(result.a_N_per_A, result.b_N_per_A, q) - physics_target(physics_a, physics_b, q);
    prior += options.regularisation * options.regularisation * deviation.squaredNorm();
  }
  report.regularised_cost = report.model_fit.sum() + prior;
  report.regressors = linear_regressor_quality(fitted, features_of(fitted, pole_pitch_m, normalisation, direction),
                                               layout, nonlinear.data(), direction);
  report.excitation_gaps = excitation_gaps(fitted, pole_pitch_m);
  return result;
}

}  // namespace clm::identification
