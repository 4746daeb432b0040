#include "commutation/identification/identification.hpp"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>

namespace clm {
namespace {

// Per-sample quantities that do not depend on the parameters.
struct Features {
  Eigen::ArrayXd cos_theta, sin_theta, input;
};

Features features_of(const CoilSetDataset& data, double pole_pitch_m, const PositionNormalisation& normalisation) {
  Features f;
  const Eigen::ArrayXd theta = data.position_m.array() * (kTwoPi / pole_pitch_m);
  f.cos_theta = theta.cos();
  f.sin_theta = theta.sin();
  f.input = (data.position_m.array() - normalisation.offset_m) / normalisation.scale_m;
  return f;
}

void check_data(const CoilSetDataset& data, const char* what) {
  if (data.size() < 10) throw std::invalid_argument(std::string(what) + " data has fewer than 10 samples");
  if (data.currents_A.cols() != data.size() || data.wrench.cols() != data.size() ||
      static_cast<Eigen::Index>(data.group.size()) != data.size()) {
    throw std::invalid_argument(std::string(what) + " data columns have different lengths");
  }
}

// Layout of the parameters of one direction in which the PGNN is linear
// (eq. 29): [A_q (2), B_q (2), W_a (n_a), b_a, W_b (n_b), b_b, W_cog (n_c), b_cog].
struct Layout {
  int column_hidden;
  int cogging_hidden;
  int linear_size() const { return 4 + 2 * (column_hidden + 1) + cogging_hidden + 1; }
  int column_a_offset() const { return 4; }
  int column_b_offset() const { return 4 + column_hidden + 1; }
  int cogging_offset() const { return 4 + 2 * (column_hidden + 1); }
  // Hidden layers (eq. 29's θ_NL): [w_a, b_a, w_b, b_b, w_cog, b_cog].
  int nonlinear_size() const { return 4 * column_hidden + 2 * cogging_hidden; }
};

constexpr int kMaxRegressor = 4 + 2 * (Network::kMaxWidth + 1) + Network::kMaxWidth + 1;

// Regressor M(θ_NL, t) of eq. (28) (the same for all three directions) and,
// optionally, the hidden activations.
void regressor(const Layout& layout, const double* nonlinear, double c, double s, double x, double ia, double ib,
               double* m, double* hidden_a, double* hidden_b, double* hidden_cog) {
  m[0] = c * ia;
  m[1] = c * ib;
  m[2] = s * ia;
  m[3] = s * ib;
  const int na = layout.column_hidden;
  const int nc = layout.cogging_hidden;
  const double* wa = nonlinear;
  const double* ba = wa + na;
  const double* wb = ba + na;
  const double* bb = wb + na;
  const double* wc = bb + na;
  const double* bc = wc + nc;
  for (int j = 0; j < na; ++j) {
    hidden_a[j] = 1.0 - 2.0 / (1.0 + std::exp(2.0 * (wa[j] * x + ba[j])));
    hidden_b[j] = 1.0 - 2.0 / (1.0 + std::exp(2.0 * (wb[j] * x + bb[j])));
    m[layout.column_a_offset() + j] = hidden_a[j] * ia;
    m[layout.column_b_offset() + j] = hidden_b[j] * ib;
  }
  m[layout.column_a_offset() + na] = ia;
  m[layout.column_b_offset() + na] = ib;
  for (int j = 0; j < nc; ++j) {
    hidden_cog[j] = 1.0 - 2.0 / (1.0 + std::exp(2.0 * (wc[j] * x + bc[j])));
    m[layout.cogging_offset() + j] = hidden_cog[j];
  }
  m[layout.cogging_offset() + nc] = 1.0;
}

// Residuals sqrt(2/N)·(F_q − F̂_q) of a chunk of samples in one direction,
// with the analytic Jacobian.
class ChunkCost final : public ceres::CostFunction {
 public:
  ChunkCost(const CoilSetDataset& data, const Features& features, const Layout& layout, int direction,
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
      regressor(layout_, nonlinear, features_.cos_theta[t], features_.sin_theta[t], x, ia, ib, m, ha, hb, hc);
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
  const Features& features_;
  Layout layout_;
  int direction_;
  Eigen::Index begin_, end_;
  double scale_;
};

// sqrt(2)·λ·(θ_phy,q − θ*_phy,q): the regularisation term of eq. (26).
class PhysicsPrior final : public ceres::CostFunction {
 public:
  PhysicsPrior(const Layout& layout, const Eigen::Vector4d& target, double weight) : target_(target), weight_(weight) {
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

// θ*_phy,q of one direction in layout order [A_q0, A_q1, B_q0, B_q1].
Eigen::Vector4d physics_target(const CoilGain& a, const CoilGain& b, int q) {
  return {a(q, 0), a(q, 1), b(q, 0), b(q, 1)};
}

// Eq. (31) for one coil set, given the hidden layers in `nonlinear`; writes the
// three directions' linear parameters.
void ridge_linear(const CoilSetDataset& data, const Features& f, const Layout& layout, const double* nonlinear,
                  const CoilGain& physics_a, const CoilGain& physics_b, double regularisation,
                  Eigen::Matrix<double, Eigen::Dynamic, 3>& linear) {
  const int p = layout.linear_size();
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(p, p);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(p, 3);
  double m[kMaxRegressor];
  double ha[Network::kMaxWidth], hb[Network::kMaxWidth], hc[Network::kMaxWidth];
  const double inv_n = 1.0 / static_cast<double>(data.size());
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    regressor(layout, nonlinear, f.cos_theta[t], f.sin_theta[t], f.input[t], data.currents_A(0, t),
              data.currents_A(1, t), m, ha, hb, hc);
    const Eigen::Map<const Eigen::VectorXd> mv(m, p);
    gram.selfadjointView<Eigen::Lower>().rankUpdate(mv, inv_n);
    rhs.noalias() += mv * (data.wrench.col(t).transpose() * inv_n);
  }
  gram = gram.selfadjointView<Eigen::Lower>();
  const double lambda2 = regularisation * regularisation;
  for (int k = 0; k < 4; ++k) gram(k, k) += lambda2;
  for (int q = 0; q < 3; ++q) rhs.block<4, 1>(0, q) += lambda2 * physics_target(physics_a, physics_b, q);
  // A tiny ridge on the output layers keeps the solve defined when a neuron is
  // saturated over the whole stroke (a constant column duplicates the bias).
  for (int k = 4; k < p; ++k) gram(k, k) += 1e-10 * (1.0 + gram(k, k));
  linear = gram.ldlt().solve(rhs);
}

// Writes the hidden and linear parameters into networks of `coil_set`.
void unpack(const Layout& layout, const double* nonlinear, const Eigen::Matrix<double, Eigen::Dynamic, 3>& linear,
            CoilSetModel& coil_set) {
  const int na = layout.column_hidden;
  const int nc = layout.cogging_hidden;
  coil_set.column_a = Network::zeros({na});
  coil_set.column_b = Network::zeros({na});
  coil_set.cogging = Network::zeros({nc});
  for (int j = 0; j < na; ++j) {
    coil_set.column_a.layers[0].weights(j, 0) = nonlinear[j];
    coil_set.column_a.layers[0].biases[j] = nonlinear[na + j];
    coil_set.column_b.layers[0].weights(j, 0) = nonlinear[2 * na + j];
    coil_set.column_b.layers[0].biases[j] = nonlinear[3 * na + j];
  }
  for (int j = 0; j < nc; ++j) {
    coil_set.cogging.layers[0].weights(j, 0) = nonlinear[4 * na + j];
    coil_set.cogging.layers[0].biases[j] = nonlinear[4 * na + nc + j];
  }
  for (int q = 0; q < 3; ++q) {
    coil_set.a_N_per_A(q, 0) = linear(0, q);
    coil_set.a_N_per_A(q, 1) = linear(1, q);
    coil_set.b_N_per_A(q, 0) = linear(2, q);
    coil_set.b_N_per_A(q, 1) = linear(3, q);
    for (int j = 0; j < na; ++j) {
      coil_set.column_a.layers[1].weights(q, j) = linear(layout.column_a_offset() + j, q);
      coil_set.column_b.layers[1].weights(q, j) = linear(layout.column_b_offset() + j, q);
    }
    coil_set.column_a.layers[1].biases[q] = linear(layout.column_a_offset() + na, q);
    coil_set.column_b.layers[1].biases[q] = linear(layout.column_b_offset() + na, q);
    for (int j = 0; j < nc; ++j) coil_set.cogging.layers[1].weights(q, j) = linear(layout.cogging_offset() + j, q);
    coil_set.cogging.layers[1].biases[q] = linear(layout.cogging_offset() + nc, q);
  }
}

// Reads the parameters back from networks (inverse of unpack).
void pack(const Layout& layout, const CoilSetModel& coil_set, std::vector<double>& nonlinear,
          Eigen::Matrix<double, Eigen::Dynamic, 3>& linear) {
  const int na = layout.column_hidden;
  const int nc = layout.cogging_hidden;
  nonlinear.assign(static_cast<std::size_t>(layout.nonlinear_size()), 0.0);
  for (int j = 0; j < na; ++j) {
    nonlinear[static_cast<std::size_t>(j)] = coil_set.column_a.layers[0].weights(j, 0);
    nonlinear[static_cast<std::size_t>(na + j)] = coil_set.column_a.layers[0].biases[j];
    nonlinear[static_cast<std::size_t>(2 * na + j)] = coil_set.column_b.layers[0].weights(j, 0);
    nonlinear[static_cast<std::size_t>(3 * na + j)] = coil_set.column_b.layers[0].biases[j];
  }
  for (int j = 0; j < nc; ++j) {
    nonlinear[static_cast<std::size_t>(4 * na + j)] = coil_set.cogging.layers[0].weights(j, 0);
    nonlinear[static_cast<std::size_t>(4 * na + nc + j)] = coil_set.cogging.layers[0].biases[j];
  }
  linear.resize(layout.linear_size(), 3);
  for (int q = 0; q < 3; ++q) {
    linear(0, q) = coil_set.a_N_per_A(q, 0);
    linear(1, q) = coil_set.a_N_per_A(q, 1);
    linear(2, q) = coil_set.b_N_per_A(q, 0);
    linear(3, q) = coil_set.b_N_per_A(q, 1);
    for (int j = 0; j < na; ++j) {
      linear(layout.column_a_offset() + j, q) = coil_set.column_a.layers[1].weights(q, j);
      linear(layout.column_b_offset() + j, q) = coil_set.column_b.layers[1].weights(q, j);
    }
    linear(layout.column_a_offset() + na, q) = coil_set.column_a.layers[1].biases[q];
    linear(layout.column_b_offset() + na, q) = coil_set.column_b.layers[1].biases[q];
    for (int j = 0; j < nc; ++j) linear(layout.cogging_offset() + j, q) = coil_set.cogging.layers[1].weights(q, j);
    linear(layout.cogging_offset() + nc, q) = coil_set.cogging.layers[1].biases[q];
  }
}

// Levenberg–Marquardt with the tolerances both PGNN solvers use; the caller
// chooses the linear solver.
ceres::Solver::Options levenberg_marquardt_options(int max_iterations, int threads) {
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = max_iterations;
  options.num_threads = threads;
  options.function_tolerance = 1e-10;
  options.gradient_tolerance = 1e-12;
  options.parameter_tolerance = 1e-10;
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
double levenberg_marquardt(const CoilSetDataset& data, const Features& f, const Layout& layout,
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
// so Ceres' cost ½‖r‖² is eq. (26) exactly. With A = ∂r/∂θ_L (the same
// M for all three directions) and V_q = ∂r_q/∂θ_NL at fixed θ_L, Kaufman's
// Jacobian is J_q = (I − A (AᵀA)⁻¹ Aᵀ) V_q: the change of θ_L with θ_NL
// projected out, without the second-order term in the residual.
class ProjectedCost final : public ceres::CostFunction {
 public:
  ProjectedCost(const CoilSetDataset& data, const Features& features, const Layout& layout,
                const CoilGain& physics_a, const CoilGain& physics_b, double regularisation)
      : data_(data), features_(features), layout_(layout), physics_a_(physics_a), physics_b_(physics_b),
        regularisation_(regularisation) {
    set_num_residuals(static_cast<int>(3 * data.size() + 12));
    mutable_parameter_block_sizes()->push_back(layout.nonlinear_size());
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* nonlinear = parameters[0];
    const Eigen::Index n = data_.size();
    const int p = layout_.linear_size();
    const int q = layout_.nonlinear_size();
    const int na = layout_.column_hidden;
    const int nc = layout_.cogging_hidden;
    const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
    Eigen::MatrixXd regressors(n, p);
    Eigen::MatrixXd derivatives;  // ∂(hidden output)/∂θ_NL times the multiplier, per column of θ_NL
    if (want_jacobian) derivatives.resize(n, q);
    double m[kMaxRegressor];
    double ha[Network::kMaxWidth], hb[Network::kMaxWidth], hc[Network::kMaxWidth];
    for (Eigen::Index t = 0; t < n; ++t) {
      const double x = features_.input[t];
      const double ia = data_.currents_A(0, t);
      const double ib = data_.currents_A(1, t);
      regressor(layout_, nonlinear, features_.cos_theta[t], features_.sin_theta[t], x, ia, ib, m, ha, hb, hc);
      for (int k = 0; k < p; ++k) regressors(t, k) = m[k];
      if (!want_jacobian) continue;
      const auto fill = [&](int first, const double* h, int width, double multiplier) {
        for (int j = 0; j < width; ++j) {
          const double g = (1.0 - h[j] * h[j]) * multiplier;
          derivatives(t, first + j) = g * x;
          derivatives(t, first + width + j) = g;
        }
      };
      fill(0, ha, na, ia);
      fill(2 * na, hb, na, ib);
      fill(4 * na, hc, nc, 1.0);
    }
    // θ_L by eq. (31) (the normal equations of r over θ_L, halved).
    const double inv_n = 1.0 / static_cast<double>(n);
    Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(p, p);
    gram.selfadjointView<Eigen::Lower>().rankUpdate(regressors.transpose(), inv_n);
    gram = gram.selfadjointView<Eigen::Lower>();
    Eigen::MatrixXd rhs = regressors.transpose() * data_.wrench.transpose() * inv_n;
    const double lambda2 = regularisation_ * regularisation_;
    Eigen::Matrix<double, 4, 3> target;
    for (int d = 0; d < 3; ++d) target.col(d) = physics_target(physics_a_, physics_b_, d);
    for (int k = 0; k < 4; ++k) gram(k, k) += lambda2;
    rhs.topRows<4>() += lambda2 * target;
    for (int k = 4; k < p; ++k) gram(k, k) += 1e-10 * (1.0 + gram(k, k));
    const Eigen::LDLT<Eigen::MatrixXd> solver(gram);
    const Eigen::MatrixXd linear = solver.solve(rhs);  // p × 3

    const double scale = std::sqrt(2.0 * inv_n);
    const double prior_weight = std::sqrt(2.0) * regularisation_;
    Eigen::Map<Eigen::MatrixXd> data_residuals(residuals, n, 3);
    data_residuals = scale * (data_.wrench.transpose() - regressors * linear);
    for (int d = 0; d < 3; ++d) {
      residuals[3 * n + 4 * d + 0] = prior_weight * (linear(0, d) - target(0, d));
      residuals[3 * n + 4 * d + 1] = prior_weight * (linear(1, d) - target(1, d));
      residuals[3 * n + 4 * d + 2] = prior_weight * (linear(2, d) - target(2, d));
      residuals[3 * n + 4 * d + 3] = prior_weight * (linear(3, d) - target(3, d));
    }
    if (!want_jacobian) return true;

    // V_q = −scale·P·diag(w_q), w_q the output weight of each hidden neuron in
    // direction q; AᵀA = 2·gram; Aᵀ V_q = scale²·(MᵀP)·diag(w_q).
    // K_q = (AᵀA)⁻¹ Aᵀ V_q; J_q = scale·(M K_q − P diag(w_q)) on the data rows,
    // −sqrt(2)·λ·K_q[0:4] on the prior rows.
    const Eigen::MatrixXd cross = regressors.transpose() * derivatives;  // p × q
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::Map<RowMajor> jacobian(jacobians[0], 3 * n + 12, q);
    Eigen::VectorXd weights(q);
    for (int d = 0; d < 3; ++d) {
      for (int j = 0; j < na; ++j) {
        weights[j] = weights[na + j] = linear(layout_.column_a_offset() + j, d);
        weights[2 * na + j] = weights[3 * na + j] = linear(layout_.column_b_offset() + j, d);
      }
      for (int j = 0; j < nc; ++j) weights[4 * na + j] = weights[4 * na + nc + j] = linear(layout_.cogging_offset() + j, d);
      // (AᵀA)⁻¹ Aᵀ V_q = (2·gram)⁻¹ · scale² · cross·diag(w) = gram⁻¹ · cross·diag(w) / n.
      const Eigen::MatrixXd k = solver.solve(cross * weights.asDiagonal()) * inv_n;
      jacobian.middleRows(d * n, n) = scale * (regressors * k - derivatives * weights.asDiagonal());
      jacobian.middleRows(3 * n + 4 * d, 4) = -prior_weight * k.topRows<4>();
    }
    return true;
  }

 private:
  const CoilSetDataset& data_;
  const Features& features_;
  Layout layout_;
  CoilGain physics_a_, physics_b_;
  double regularisation_;
};

// Levenberg–Marquardt on θ_NL of the variable-projection problem; θ_L by
// eq. (31) afterwards. Returns the final cost (eq. 26) and adds the iterations.
double variable_projection(const CoilSetDataset& data, const Features& f, const Layout& layout,
                           const CoilGain& physics_a, const CoilGain& physics_b, double regularisation,
                           int max_iterations, int threads, std::vector<double>& nonlinear,
                           Eigen::Matrix<double, Eigen::Dynamic, 3>& linear, int& iterations) {
  ceres::Problem problem;
  problem.AddResidualBlock(new ProjectedCost(data, f, layout, physics_a, physics_b, regularisation), nullptr,
                           nonlinear.data());
  ceres::Solver::Options options = levenberg_marquardt_options(max_iterations, threads);
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  const ceres::Solver::Summary summary = solve_counting(options, problem, iterations);
  ridge_linear(data, f, layout, nonlinear.data(), physics_a, physics_b, regularisation, linear);
  return summary.final_cost;
}

CoilSetDataset decimate(const CoilSetDataset& data, int every) {
  std::vector<Eigen::Index> indices;
  for (Eigen::Index i = 0; i < data.size(); i += std::max(1, every)) indices.push_back(i);
  return data.subset(indices);
}

ElectromagneticModel single_coil_set_model(ModelKind kind, double pole_pitch_m, const PositionNormalisation& normalisation,
                                           const UniformCubicBasis& basis, const CoilSetModel& coil_set) {
  ElectromagneticModel model;
  model.kind = kind;
  model.pole_pitch_m = pole_pitch_m;
  model.normalisation = normalisation;
  model.spline_basis = basis;
  model.coil_sets.push_back(coil_set);
  return model;
}

void fill_costs(const ElectromagneticModel& model, const ElectromagneticModel& physics,
                const CoilSetDataset& training, const CoilSetDataset& validation, IdentificationReport& report) {
  report.model_training = coil_set_cost(model, 0, training);
  report.physics_training = coil_set_cost(physics, 0, training);
  if (validation.size() > 0) {
    report.model_validation = coil_set_cost(model, 0, validation);
    report.physics_validation = coil_set_cost(physics, 0, validation);
  }
  for (int q = 0; q < 3; ++q) {
    report.proposition_holds[q] = report.model_training[q] <= report.physics_training[q] * (1.0 + 1e-9) + 1e-12;
  }
}

}  // namespace

DirectionCost coil_set_cost(const ElectromagneticModel& model, int coil_set, const CoilSetDataset& data) {
  DirectionCost cost = DirectionCost::Zero();
  if (data.size() == 0) return cost;
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    CoilGain gain;
    Wrench cogging;
    model.evaluate_coil_set(coil_set, data.position_m[t], gain, cogging);
    const Wrench error = data.wrench.col(t) - gain * data.currents_A.col(t) - cogging;
    cost += error.cwiseAbs2();
  }
  return cost / static_cast<double>(data.size());
}

void fit_physics_only(const CoilSetDataset& data, double pole_pitch_m, CoilGain& a, CoilGain& b) {
  check_data(data, "physics-only fit:");
  Eigen::Matrix4d gram = Eigen::Matrix4d::Zero();
  Eigen::Matrix<double, 4, 3> rhs = Eigen::Matrix<double, 4, 3>::Zero();
  for (Eigen::Index t = 0; t < data.size(); ++t) {
    const double theta = electrical_angle_rad(data.position_m[t], pole_pitch_m);
    const double c = std::cos(theta), s = std::sin(theta);
    const double ia = data.currents_A(0, t), ib = data.currents_A(1, t);
    const Eigen::Vector4d m(c * ia, c * ib, s * ia, s * ib);
    gram.noalias() += m * m.transpose();
    rhs.noalias() += m * data.wrench.col(t).transpose();
  }
  Eigen::LDLT<Eigen::Matrix4d> solver(gram);
  if (solver.info() != Eigen::Success || solver.rcond() < 1e-12) {
    throw std::invalid_argument("physics-only fit is singular: the currents do not excite both columns of K");
  }
  const Eigen::Matrix<double, 4, 3> solution = solver.solve(rhs);
  for (int q = 0; q < 3; ++q) {
    a(q, 0) = solution(0, q);
    a(q, 1) = solution(1, q);
    b(q, 0) = solution(2, q);
    b(q, 1) = solution(3, q);
  }
}

PositionNormalisation normalisation_for(const Eigen::VectorXd& position_m) {
  const double low = position_m.minCoeff();
  const double high = position_m.maxCoeff();
  const double half = 0.5 * (high - low);
  return {0.5 * (high + low), half > 0.0 ? half : 1.0};
}

void solve_linear_parameters(const CoilSetDataset& data, double pole_pitch_m,
                             const PositionNormalisation& normalisation, const CoilGain& physics_a,
                             const CoilGain& physics_b, double regularisation, CoilSetModel& coil_set) {
  const Layout layout{static_cast<int>(coil_set.column_a.layers[0].biases.size()),
                      static_cast<int>(coil_set.cogging.layers[0].biases.size())};
  std::vector<double> nonlinear;
  Eigen::Matrix<double, Eigen::Dynamic, 3> linear;
  pack(layout, coil_set, nonlinear, linear);
  const Features f = features_of(data, pole_pitch_m, normalisation);
  ridge_linear(data, f, layout, nonlinear.data(), physics_a, physics_b, regularisation, linear);
  unpack(layout, nonlinear.data(), linear, coil_set);
}

CoilSetModel identify_pgnn_coil_set(const CoilSetDataset& training, const CoilSetDataset& validation,
                                    double pole_pitch_m, const PositionNormalisation& normalisation,
                                    const PgnnOptions& options, IdentificationReport& report,
                                    const std::function<void(const PgnnProgress&)>& progress) {
  check_data(training, "training");
  if (options.column_hidden < 1 || options.column_hidden > Network::kMaxWidth || options.cogging_hidden < 1 ||
      options.cogging_hidden > Network::kMaxWidth) {
    throw std::invalid_argument("network sizes must lie in 1.." + std::to_string(Network::kMaxWidth));
  }
  if (options.restarts < 1) throw std::invalid_argument("at least one restart is needed");
  if (!(options.regularisation >= 0.0)) throw std::invalid_argument("regularisation must be non-negative");

  CoilGain physics_a, physics_b;
  fit_physics_only(training, pole_pitch_m, physics_a, physics_b);
  const Layout layout{options.column_hidden, options.cogging_hidden};
  const auto solve = options.solver == PgnnSolver::kVariableProjection ? variable_projection : levenberg_marquardt;

  const CoilSetDataset coarse = decimate(training, options.restart_decimation);
  const Features coarse_features = features_of(coarse, pole_pitch_m, normalisation);
  const CoilSetDataset polish = decimate(training, options.final_decimation);
  const Features polish_features = features_of(polish, pole_pitch_m, normalisation);
  const Features full_features = features_of(training, pole_pitch_m, normalisation);

  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> slope(-4.0, 4.0);
  std::uniform_real_distribution<double> centre(-1.0, 1.0);
  double best_cost = std::numeric_limits<double>::infinity();
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
    if (cost < best_cost) {
      best_cost = cost;
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

  CoilSetModel result;
  unpack(layout, best_nonlinear.data(), best_linear, result);
  CoilSetModel physics;
  physics.a_N_per_A = physics_a;
  physics.b_N_per_A = physics_b;
  physics.column_a = Network::zeros({layout.column_hidden});
  physics.column_b = Network::zeros({layout.column_hidden});
  physics.cogging = Network::zeros({layout.cogging_hidden});
  const auto model = single_coil_set_model(ModelKind::kPgnn, pole_pitch_m, normalisation, {}, result);
  const auto physics_model = single_coil_set_model(ModelKind::kPgnn, pole_pitch_m, normalisation, {}, physics);
  fill_costs(model, physics_model, training, validation, report);
  Eigen::Vector4d deviation;
  double prior = 0.0;
  for (int q = 0; q < 3; ++q) {
    deviation = physics_target(result.a_N_per_A, result.b_N_per_A, q) - physics_target(physics_a, physics_b, q);
    prior += options.regularisation * options.regularisation * deviation.squaredNorm();
  }
  report.regularised_cost = report.model_training.sum() + prior;
  return result;
}

UniformCubicBasis spline_basis_for(const Eigen::VectorXd& position_m, double pole_pitch_m, const SplineOptions& options) {
  const double spacing = options.knot_spacing_m > 0.0 ? options.knot_spacing_m : pole_pitch_m / 8.0;
  const double low = position_m.minCoeff();
  const double high = position_m.maxCoeff();
  const int intervals = std::max(1, static_cast<int>(std::ceil((high - low) / spacing)));
  const double centre = 0.5 * (low + high);
  const double half = 0.5 * intervals * spacing;
  return {centre - half, centre + half, intervals};
}

CoilSetModel identify_spline_coil_set(const CoilSetDataset& training, const CoilSetDataset& validation,
                                      double pole_pitch_m, const UniformCubicBasis& basis,
                                      const SplineOptions& options, IdentificationReport& report) {
  check_data(training, "training");
  if (!(options.smoothing >= 0.0) || !(options.regularisation >= 0.0)) {
    throw std::invalid_argument("spline smoothing and regularisation must be non-negative");
  }
  CoilGain physics_a, physics_b;
  fit_physics_only(training, pole_pitch_m, physics_a, physics_b);
  const int n = basis.size();
  const int p = 4 + 3 * n;  // [A_q, B_q, C_a (n), C_b (n), G (n)]
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(p, p);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(p, 3);
  const double inv_n = 1.0 / static_cast<double>(training.size());
  for (Eigen::Index t = 0; t < training.size(); ++t) {
    const double y = training.position_m[t];
    const double theta = electrical_angle_rad(y, pole_pitch_m);
    const double c = std::cos(theta), s = std::sin(theta);
    const double ia = training.currents_A(0, t), ib = training.currents_A(1, t);
    const auto span = basis.evaluate(y);
    int index[16];
    double value[16];
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
    for (int r = 0; r < 16; ++r) {
      for (int k = 0; k < 16; ++k) gram(index[r], index[k]) += inv_n * value[r] * value[k];
      for (int q = 0; q < 3; ++q) rhs(index[r], q) += inv_n * value[r] * training.wrench(q, t);
    }
  }
  // Roughness penalty: squared second differences of each coefficient row.
  for (int block = 0; block < 3; ++block) {
    const int first = 4 + block * n;
    for (int j = 0; j + 2 < n; ++j) {
      const int idx[3] = {first + j, first + j + 1, first + j + 2};
      const double d[3] = {1.0, -2.0, 1.0};
      for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) gram(idx[r], idx[k]) += options.smoothing * d[r] * d[k];
      }
    }
  }
  const double lambda2 = options.regularisation * options.regularisation;
  for (int k = 0; k < 4; ++k) gram(k, k) += lambda2;
  for (int q = 0; q < 3; ++q) rhs.block<4, 1>(0, q) += lambda2 * physics_target(physics_a, physics_b, q);
  for (int k = 4; k < p; ++k) gram(k, k) += 1e-12 * (1.0 + gram(k, k));
  const Eigen::MatrixXd solution = gram.ldlt().solve(rhs);
  if (!solution.allFinite()) throw std::invalid_argument("spline least-squares problem is singular");

  CoilSetModel result;
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
  }
  CoilSetModel physics;
  physics.a_N_per_A = physics_a;
  physics.b_N_per_A = physics_b;
  physics.column_a_spline = SplineCoefficients::Zero(3, n);
  physics.column_b_spline = SplineCoefficients::Zero(3, n);
  physics.cogging_spline = SplineCoefficients::Zero(3, n);
  const auto model = single_coil_set_model(ModelKind::kSpline, pole_pitch_m, {}, basis, result);
  const auto physics_model = single_coil_set_model(ModelKind::kSpline, pole_pitch_m, {}, basis, physics);
  fill_costs(model, physics_model, training, validation, report);
  report.regularised_cost = report.model_training.sum();
  report.best_restart = 0;
  report.iterations = 0;
  return result;
}

}  // namespace clm
