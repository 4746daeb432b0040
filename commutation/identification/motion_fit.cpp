#include "commutation/identification/motion_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "commutation/classical.hpp"
#include "commutation/elementary.hpp"
#include "commutation/identification/spline_fit.hpp"

namespace clm::identification {
namespace {

/// One row of the balance as (index, value) pairs; an index may repeat, the
/// row being their sum, until compact() merges them. Two positions per
/// setpoint paired × (4 physics + 3 × 4 spline) + 2 friction.
struct SparseRow {
  static constexpr int kCapacity = 2 * PairingWeights::kMaxSetpoints * 16 + 2;
  struct Entry {
    int index;
    double value;
  };
  std::array<Entry, kCapacity> entries{};
  int size = 0;
  void add(int i, double v) { entries[static_cast<std::size_t>(size++)] = {i, v}; }
  /// Sorts by index and merges repeats: the normal equations then cost the
  /// square of the distinct unknowns, not of the entries.
  void compact() {
    const auto end = entries.begin() + size;
    std::sort(entries.begin(), end, [](const Entry& a, const Entry& b) { return a.index < b.index; });
    int out = 0;
    for (auto it = entries.begin(); it != end; ++it) {
      if (out > 0 && entries[static_cast<std::size_t>(out - 1)].index == it->index) {
        entries[static_cast<std::size_t>(out - 1)].value += it->value;
      } else {
        entries[static_cast<std::size_t>(out++)] = *it;
      }
    }
    size = out;
  }
  double dot(const Eigen::VectorXd& x) const {
    double sum = 0.0;
    for (int k = 0; k < size; ++k) sum += entries[static_cast<std::size_t>(k)].value * x[entries[static_cast<std::size_t>(k)].index];
    return sum;
  }
};

/// Regressor of the driving force of currents `i` at `position_m` into the
/// y-row parameters [A_y0, A_y1, B_y0, B_y1, C_a (n), C_b (n), G (n)], added
/// with `weight` into `row`.
void add_force_regressor(double position_m, const Eigen::Vector2d& i, double pole_pitch_m,
                         const UniformCubicBasis& basis, double weight, SparseRow& row) {
  const double theta = electrical_angle_rad(position_m, pole_pitch_m);
  const auto [s, c] = elementary::sin_cos(theta);
  const int n = basis.size();
  row.add(0, weight * c * i[0]);
  row.add(1, weight * c * i[1]);
  row.add(2, weight * s * i[0]);
  row.add(3, weight * s * i[1]);
  const auto span = basis.evaluate(position_m);
  for (int k = 0; k < 4; ++k) {
    const double b = weight * span.value[static_cast<std::size_t>(k)];
    row.add(4 + span.first + k, b * i[0]);
    row.add(4 + n + span.first + k, b * i[1]);
    row.add(4 + 2 * n + span.first + k, b);
  }
}

/// ∫_lo^hi (α + β·x)·g(x − a) dx with g(u) = 1 − e^(−ω·u) for u ≥ 0 and 0
/// before: the hat's piece α + β·x times the share of a setpoint's force a
/// step at `a` has brought; ω infinite: the unit step. Every exponent is ≤ 0.
double hat_times_step(double lo, double hi, double alpha, double beta, double omega, double a) {
  lo = std::max(lo, a);
  if (!(hi > lo)) return 0.0;
  const double u0 = lo - a, u1 = hi - a, c0 = alpha + beta * a;
  double integral = c0 * (u1 - u0) + 0.5 * beta * (u1 * u1 - u0 * u0);
  if (std::isfinite(omega)) {
    // ∫ (c0 + β·u)·e^(−ω·u) du = −e^(−ω·u)·((c0 + β·u)/ω + β/ω²)
    const auto primitive = [&](double u) {
      return -elementary::exp(-omega * u) * ((c0 + beta * u) / omega + beta / (omega * omega));
    };
    integral -= primitive(u1) - primitive(u0);
  }
  return integral;
}

/// Calls `use(acceleration)` for every row of `runs` the fit uses, with
/// `row` set to its regressor (compacted): the model's y-row parameters over
/// m, then −v and −tanh(v/v_d) (the header's balance).
template <typename Use>
void for_each_balance(const std::vector<MotionRun>& runs, double pole_pitch_m, const UniformCubicBasis& basis,
                      const MotionFitOptions& options, SparseRow& row, Use&& use) {
  const int model = 4 + 3 * basis.size();
  for (const MotionRun& run : runs) {
    const Eigen::Index samples = run.position_m.size();
    if (run.time_s.size() != samples || run.currents_A.cols() != samples ||
        (run.currents_next_A.size() != 0 && run.currents_next_A.cols() != samples)) {
      throw std::invalid_argument("motion fit: a run's times, positions and currents have different lengths");
    }
    const auto& currents_next = run.currents_next_A.size() != 0 ? run.currents_next_A : run.currents_A;
    if (samples < 3) continue;
    const double period_s = (run.time_s[samples - 1] - run.time_s[0]) / static_cast<double>(samples - 1);
    for (Eigen::Index k = 1; k < samples; ++k) {
      const double step = run.time_s[k] - run.time_s[k - 1];
      if (!(std::abs(step - period_s) <= 1e-6 * period_s)) {
        throw std::invalid_argument("motion fit: a run's time steps are not equal");
      }
    }
    const PairingWeights weights = pairing_weights(options.current_loop, options.delay_s, period_s);
    const auto middle_m = [&](Eigen::Index j) { return 0.5 * (run.position_m[j] + run.position_m[j + 1]); };
    for (Eigen::Index k = std::max<Eigen::Index>(1, weights.count - 1); k + 1 < samples; ++k) {
      const double acceleration = (run.position_m[k + 1] - 2.0 * run.position_m[k] + run.position_m[k - 1]) /
                                  (period_s * period_s);
      const double velocity = (run.position_m[k + 1] - run.position_m[k - 1]) / (2.0 * period_s);
      if (std::abs(velocity) < options.min_speed_m_per_s) continue;
      row.size = 0;
      // Each setpoint's force inside its own period, at that period's middle
      // position, and in the periods after it, at the next period's.
      for (int n = 0; n < weights.count; ++n) {
        const Eigen::Index j = k - n;
        const auto u = static_cast<std::size_t>(n);
        if (weights.own[u] != 0.0) {
          add_force_regressor(middle_m(j), run.currents_A.col(j), pole_pitch_m, basis, weights.own[u], row);
        }
        if (weights.later[u] != 0.0) {
          add_force_regressor(middle_m(j + 1), currents_next.col(j), pole_pitch_m, basis, weights.later[u], row);
        }
      }
      row.add(model, -velocity);
      row.add(model + 1, -elementary::tanh(velocity / options.direction_smoothing_m_per_s));
      row.compact();
      use(acceleration);
    }
  }
}

/// [A_y, B_y] of the drive's nominal commutation (eq. 7 with k̂_d, ζ̂_d).
Eigen::Vector4d nominal_physics(const DriveCommutation& drive) {
  CoilGain a, b;
  classical_physics_parameters({drive.motor_constant_N_per_A, drive.phase_offset_rad, 0.0, 0.0}, a, b);
  return {a(0, 0), a(0, 1), b(0, 0), b(0, 1)};
}

/// The balance's normal equations (per kilogram): Σ rowᵀrow, Σ rowᵀ·acceleration, Σ acceleration².
struct NormalEquations {
  Eigen::MatrixXd gram;
  Eigen::VectorXd rhs;
  double rhs_square_sum = 0.0;
  Eigen::Index rows = 0;
};

NormalEquations accumulate(const std::vector<MotionRun>& runs, double pole_pitch_m, const UniformCubicBasis& basis,
                           const MotionFitOptions& options) {
  // The balance divided by the mass: the measured acceleration is the
  // target, so the positions' noise stays out of the regressors (a mass
  // fitted beside a noisy acceleration would be biased towards zero).
  // Unknowns: the model's y-row over m, then f_v/m and f_d/m.
  const int p = 4 + 3 * basis.size() + 2;
  NormalEquations eq{Eigen::MatrixXd::Zero(p, p), Eigen::VectorXd::Zero(p), 0.0, 0};
  SparseRow row;
  for_each_balance(runs, pole_pitch_m, basis, options, row, [&](double acceleration) {
    for (int a = 0; a < row.size; ++a) {
      const auto& ea = row.entries[static_cast<std::size_t>(a)];
      eq.rhs[ea.index] += ea.value * acceleration;
      for (int b = 0; b < row.size; ++b) {
        const auto& eb = row.entries[static_cast<std::size_t>(b)];
        eq.gram(ea.index, eb.index) += ea.value * eb.value;
      }
    }
    eq.rhs_square_sum += acceleration * acceleration;
    ++eq.rows;
  });
  return eq;
}

Eigen::VectorXd solve(NormalEquations eq, const MotionFitOptions& options, int n) {
  const int model = 4 + 3 * n;
  // Roughness of each coefficient row, relative to the largest diagonal of
  // the data's normal matrix (the unknowns are per kilogram here).
  add_roughness_penalty(eq.gram, 4, n, 3, options.smoothing * eq.gram.diagonal().head(model).maxCoeff());
  for (Eigen::Index k = 0; k < eq.gram.rows(); ++k) eq.gram(k, k) += 1e-12 * (1.0 + eq.gram(k, k));
  Eigen::VectorXd x = eq.gram.ldlt().solve(eq.rhs);
  if (!x.allFinite()) throw std::invalid_argument("motion fit: singular problem");
  return x;
}

}  // namespace

PairingWeights pairing_weights(const CurrentLoopModel& loop, double delay_s, double period_s) {
  if (!(period_s > 0.0) || !std::isfinite(period_s) || !(delay_s >= 0.0) || !std::isfinite(delay_s)) {
    throw std::invalid_argument("pairing weights: a period not positive or a delay negative or not finite");
  }
  loop.validate();
  const double omega = loop.ideal() ? std::numeric_limits<double>::infinity() : kTwoPi * loop.bandwidth_Hz;
  const double t = period_s;
  // The hat around row k (time 0): (T + x)/T² over the period before, (T − x)/T² over the one after.
  const auto before = [&](double a) { return hat_times_step(-t, 0.0, 1.0 / t, 1.0 / (t * t), omega, a); };
  const auto after = [&](double a) { return hat_times_step(0.0, t, 1.0 / t, -1.0 / (t * t), omega, a); };
  // A force share below this (10⁻⁴ N of a 100 N force) is left to the oldest
  // setpoint kept: each setpoint more costs the fit a block of its rows.
  constexpr double kNegligibleWeight = 1e-6;
  PairingWeights weights;
  double total = 0.0;
  for (int n = 0; n < PairingWeights::kMaxSetpoints; ++n) {
    // Setpoint k − n takes effect at −n·T + delay and gives way at −(n − 1)·T + delay.
    const double on = -n * t + delay_s, off = on + t;
    const double in_before = before(on) - before(off), in_after = after(on) - after(off);
    const auto u = static_cast<std::size_t>(n);
    weights.own[u] = n == 0 ? in_after : n == 1 ? in_before : 0.0;
    weights.later[u] = in_before + in_after - weights.own[u];
    total += in_before + in_after;
    weights.count = n + 1;
    if (1.0 - total < kNegligibleWeight) break;
  }
  weights.later[static_cast<std::size_t>(weights.count - 1)] += 1.0 - total;
  return weights;
}

MotionFit MotionFit::scaled_to_mass(double new_mass_kg) const {
  const double s = new_mass_kg / mass_kg;
  MotionFit fit = *this;
  fit.a_y *= s;
  fit.b_y *= s;
  fit.column_a *= s;
  fit.column_b *= s;
  fit.cogging *= s;
  fit.viscous_N_s_per_m *= s;
  fit.direction_N *= s;
  fit.residual_rms_N *= s;
  fit.mass_kg = new_mass_kg;
  return fit;
}

double motion_residual_rms_N(const MotionFit& fit, const std::vector<MotionRun>& runs, double pole_pitch_m,
                             const UniformCubicBasis& basis, const MotionFitOptions& options) {
  const int n = basis.size();
  const int model = 4 + 3 * n;
  Eigen::VectorXd x(model + 2);
  x << fit.a_y.transpose(), fit.b_y.transpose(), fit.column_a.transpose(), fit.column_b.transpose(),
      fit.cogging.transpose(), fit.viscous_N_s_per_m, fit.direction_N;
  SparseRow row;
  double square_sum = 0.0;
  Eigen::Index rows = 0;
  for_each_balance(runs, pole_pitch_m, basis, options, row, [&](double acceleration) {
    const double residual = row.dot(x) - fit.mass_kg * acceleration;
    square_sum += residual * residual;
    ++rows;
  });
  return rows > 0 ? std::sqrt(square_sum / static_cast<double>(rows)) : std::nan("");
}

void MotionFitOptions::validate(const char* what) const {
  const auto finite = [](double x) { return std::isfinite(x); };
  if (!(mass_kg >= 0.0) || !(smoothing >= 0.0) || !(direction_smoothing_m_per_s > 0.0) ||
      !(min_speed_m_per_s >= 0.0) || !(viscous_N_s_per_m >= 0.0) || !(direction_N >= 0.0) || !finite(mass_kg) ||
      !finite(smoothing) || !finite(direction_smoothing_m_per_s) || !finite(min_speed_m_per_s) ||
      !finite(viscous_N_s_per_m) || !finite(direction_N)) {
    throw std::invalid_argument(std::string(what) +
                                ": negative or non-finite mass, smoothing, minimum speed or friction, or v_d not "
                                "positive");
  }
  if (mass_kg > 0.0 && friction_given()) {
    throw std::invalid_argument(std::string(what) + ": a mass and a friction given; each fixes the force scale, give one");
  }
}

double common_mass_kg(const std::vector<MotionFit>& fits, const MotionFitOptions& options) {
  if (options.scale() == MotionFitOptions::Scale::kMass) return options.mass_kg;
  // Least squares of mass·(per-kilogram figures) against the reference: the
  // friction given, else the nominal commutation's A_y, B_y.
  const bool friction = options.scale() == MotionFitOptions::Scale::kFriction;
  const Eigen::Vector4d nominal = nominal_physics(options.drive);
  double numerator = 0.0, denominator = 0.0;
  for (const MotionFit& fit : fits) {
    const auto add = [&](double per_kg, double reference) {
      numerator += per_kg * reference;
      denominator += per_kg * per_kg;
    };
    if (friction) {
      if (options.viscous_N_s_per_m > 0.0) add(fit.viscous_N_s_per_m / fit.mass_kg, options.viscous_N_s_per_m);
      if (options.direction_N > 0.0) add(fit.direction_N / fit.mass_kg, options.direction_N);
    } else {
      add(fit.a_y[0] / fit.mass_kg, nominal[0]);
      add(fit.a_y[1] / fit.mass_kg, nominal[1]);
      add(fit.b_y[0] / fit.mass_kg, nominal[2]);
      add(fit.b_y[1] / fit.mass_kg, nominal[3]);
    }
  }
  return numerator / denominator;
}

PayloadMass mass_from_payload(const std::vector<MotionFit>& without, const std::vector<MotionFit>& with,
                              double payload_kg, const Eigen::VectorXd& positions_m, double pole_pitch_m,
                              const UniformCubicBasis& basis) {
  if (without.size() != with.size() || without.empty() || positions_m.size() == 0) {
    throw std::invalid_argument("payload mass: the fits without and with the payload differ in coil sets, or no "
                                "positions to compare them at");
  }
  if (!(payload_kg > 0.0) || !std::isfinite(payload_kg)) {
    throw std::invalid_argument("payload mass: the payload must be positive and finite");
  }
  double numerator = 0.0, denominator = 0.0;
  for (std::size_t l = 0; l < without.size(); ++l) {
    for (const double y : positions_m) {
      // [K_a, K_b, F_cog] per kilogram of each fit at y.
      const auto per_kg = [&](const MotionFit& fit) -> Eigen::Vector3d {
        const Eigen::Matrix<double, 1, 2> k = fit.gain(y, pole_pitch_m, basis);
        return Eigen::Vector3d(k[0], k[1], fit.cogging_N(y, basis)) / fit.mass_kg;
      };
      const Eigen::Vector3d a = per_kg(without[l]), b = per_kg(with[l]);
      numerator += a.dot(b);
      denominator += b.dot(b);
    }
  }
  const double ratio = numerator / denominator;
  if (!(ratio > 1.0 + 1e-3) || !std::isfinite(ratio)) {
    throw std::invalid_argument("payload mass: the response with the payload is not slower than without (ratio " +
                                std::to_string(ratio) + "): no mass follows");
  }
  return {payload_kg / (ratio - 1.0), ratio};
}

Eigen::Matrix<double, 1, 2> MotionFit::gain(double position_m, double pole_pitch_m,
                                            const UniformCubicBasis& basis) const {
  const double theta = electrical_angle_rad(position_m, pole_pitch_m);
  const auto [s, c] = elementary::sin_cos(theta);
  Eigen::Matrix<double, 1, 2> k = a_y * c + b_y * s;
  const auto span = basis.evaluate(position_m);
  for (int j = 0; j < 4; ++j) {
    const double b = span.value[static_cast<std::size_t>(j)];
    k[0] += b * column_a[span.first + j];
    k[1] += b * column_b[span.first + j];
  }
  return k;
}

double MotionFit::cogging_N(double position_m, const UniformCubicBasis& basis) const {
  const auto span = basis.evaluate(position_m);
  double force = 0.0;
  for (int j = 0; j < 4; ++j) force += span.value[static_cast<std::size_t>(j)] * cogging[span.first + j];
  return force;
}

MotionFit fit_driving_direction_from_motion(const std::vector<MotionRun>& runs, double pole_pitch_m,
                                            const UniformCubicBasis& basis, const MotionFitOptions& options) {
  options.validate("motion fit");
  const int n = basis.size();
  const int model = 4 + 3 * n;
  const NormalEquations eq = accumulate(runs, pole_pitch_m, basis, options);
  if (eq.rows < 10) {
    throw std::invalid_argument("motion fit: fewer than 10 rows of three consecutive positions in motion");
  }
  const Eigen::VectorXd x = solve(eq, options, n);
  // The scale (MotionFitOptions): the mass given, or the one that brings the
  // per-kilogram friction or A_y, B_y closest to those given or nominal.
  MotionFit per_kg;
  per_kg.mass_kg = 1.0;
  per_kg.a_y << x[0], x[1];
  per_kg.b_y << x[2], x[3];
  per_kg.viscous_N_s_per_m = x[model];
  per_kg.direction_N = x[model + 1];
  const double mass_kg = common_mass_kg({per_kg}, options);
  if (!(mass_kg > 0.0) || !std::isfinite(mass_kg)) {
    throw std::invalid_argument("motion fit: the gains or friction identified point against the reference that "
                                "sets the scale; no mass");
  }

  MotionFit fit;
  const Eigen::VectorXd scaled = mass_kg * x;
  fit.a_y << scaled[0], scaled[1];
  fit.b_y << scaled[2], scaled[3];
  fit.column_a = scaled.segment(4, n).transpose();
  fit.column_b = scaled.segment(4 + n, n).transpose();
  fit.cogging = scaled.segment(4 + 2 * n, n).transpose();
  fit.viscous_N_s_per_m = scaled[model];
  fit.direction_N = scaled[model + 1];
  fit.mass_kg = mass_kg;
  // Σ (row·x − acceleration)² from the data's normal equations, as a force.
  const double square_sum = x.dot(eq.gram * x) - 2.0 * x.dot(eq.rhs) + eq.rhs_square_sum;
  fit.residual_rms_N = mass_kg * std::sqrt(std::max(0.0, square_sum) / static_cast<double>(eq.rows));
  fit.rows = eq.rows;
  return fit;
}

}  // namespace clm::identification
