#pragma once
// The parameters in which the PGNN is linear (θ_L of eq. 29): their layout,
// the regressor M(θ_NL, t) of eq. (28), and eq. (31), the ridge least-squares
// solve of θ_L for fixed hidden layers θ_NL. The PGNN training calls these at
// every restart and at the end; solve_linear_parameters is the public form.
// No I/O.

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "commutation/elementary.hpp"
#include "commutation/identification/dataset.hpp"
#include "commutation/identification/excitation.hpp"
#include "commutation/identification/nuisance.hpp"
#include "commutation/model.hpp"

namespace clm::identification {

/// Input normalisation mapping the positions in `data` to [−1, 1].
PositionNormalisation normalisation_for(const Eigen::VectorXd& position_m);

/// Eq. (31): ridge least squares of every parameter in which the PGNN is
/// linear (A, B, the physics-part harmonics of `harmonics` and the output
/// layers), direction by direction, with the hidden layers of `coil_set`
/// held fixed. Modifies `coil_set` in place. `direction` gives v_c of the
/// direction-dependent force fitted beside them; its amplitude is written
/// back.
void solve_linear_parameters(const CoilSetDataset& data, double pole_pitch_m,
                             const PositionNormalisation& normalisation, const HarmonicOrders& harmonics,
                             const CoilGain& physics_a, const CoilGain& physics_b, double regularisation,
                             CoilSetModel& coil_set, DirectionForce& direction);

/// Per-sample quantities that do not depend on the parameters: cos θ, sin θ
/// of the electrical angle, the normalised network input and the regressor
/// tanh(ẏ/v_c) of the direction-dependent force (zero without one).
struct PgnnFeatures {
  Eigen::ArrayXd cos_theta, sin_theta, input, direction;
};

/// The features of every sample of `data` (θ from position_m and pole_pitch_m,
/// input = (y − offset_m) / scale_m, direction from `direction`'s v_c). No
/// checks: `data` is validated by the caller.
PgnnFeatures features_of(const CoilSetDataset& data, double pole_pitch_m, const PositionNormalisation& normalisation,
                         const DirectionForce& direction);

/// Layout of the parameters of one direction in which the PGNN is linear
/// (eq. 29), then the direction-dependent force C_q (a nuisance term, not
/// part of the model): [A_q (2), B_q (2), W_a (n_a), b_a, W_b (n_b), b_b,
/// W_cog (n_c), b_cog, gain harmonics (4 per order: cos·i_a, cos·i_b,
/// sin·i_a, sin·i_b), cogging harmonics (2 per order: cos, sin), C_q].
struct PgnnLayout {
  int column_hidden;
  int cogging_hidden;
  HarmonicOrders harmonics = {};
  int gain_harmonic_count() const { return 4 * static_cast<int>(harmonics.gain.size()); }
  int cogging_harmonic_count() const { return 2 * static_cast<int>(harmonics.cogging.size()); }
  int linear_size() const {
    return 4 + 2 * (column_hidden + 1) + cogging_hidden + 1 + gain_harmonic_count() + cogging_harmonic_count() + 1;
  }
  int column_a_offset() const { return 4; }
  int column_b_offset() const { return 4 + column_hidden + 1; }
  int cogging_offset() const { return 4 + 2 * (column_hidden + 1); }
  int gain_harmonics_offset() const { return cogging_offset() + cogging_hidden + 1; }
  int cogging_harmonics_offset() const { return gain_harmonics_offset() + gain_harmonic_count(); }
  int direction_offset() const { return linear_size() - 1; }
  /// The layout of a PGNN coil set's networks with `harmonics` in its physics part.
  static PgnnLayout of(const CoilSetModel& coil_set, const HarmonicOrders& harmonics);
  // Hidden layers (eq. 29's θ_NL): [w_a, b_a, w_b, b_b, w_cog, b_cog].
  int nonlinear_size() const { return 4 * column_hidden + 2 * cogging_hidden; }
};

/// Largest linear_size() for networks of at most Network::kMaxWidth neurons
/// and every harmonic order.
constexpr int kMaxRegressor = 4 + 2 * (Network::kMaxWidth + 1) + Network::kMaxWidth + 2 + 6 * kMaxHarmonicOrder;

/// Regressor M(θ_NL, t) of eq. (28) (the same for all three directions) into
/// m[0..linear_size()), and the hidden activations into hidden_a/b/cog.
/// Inline: the cost functions of the PGNN training call it once per sample.
/// `d` is the sample's tanh(ẏ/v_c).
inline void regressor(const PgnnLayout& layout, const double* nonlinear, double c, double s, double x, double d,
                      double ia, double ib, double* m, double* hidden_a, double* hidden_b, double* hidden_cog) {
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
    hidden_a[j] = wa[j] * x + ba[j];
    hidden_b[j] = wb[j] * x + bb[j];
  }
  for (int j = 0; j < nc; ++j) hidden_cog[j] = wc[j] * x + bc[j];
  elementary::tanh_array(hidden_a, hidden_a, na);
  elementary::tanh_array(hidden_b, hidden_b, na);
  elementary::tanh_array(hidden_cog, hidden_cog, nc);
  for (int j = 0; j < na; ++j) {
    m[layout.column_a_offset() + j] = hidden_a[j] * ia;
    m[layout.column_b_offset() + j] = hidden_b[j] * ib;
  }
  m[layout.column_a_offset() + na] = ia;
  m[layout.column_b_offset() + na] = ib;
  for (int j = 0; j < nc; ++j) m[layout.cogging_offset() + j] = hidden_cog[j];
  m[layout.cogging_offset() + nc] = 1.0;
  if (!layout.harmonics.empty()) {
    double cos_n[kMaxHarmonicOrder + 1], sin_n[kMaxHarmonicOrder + 1];
    angle_harmonics(c, s, layout.harmonics.max_order(), cos_n, sin_n);
    double* gain = m + layout.gain_harmonics_offset();
    for (const int n : layout.harmonics.gain) {
      gain[0] = cos_n[n] * ia;
      gain[1] = cos_n[n] * ib;
      gain[2] = sin_n[n] * ia;
      gain[3] = sin_n[n] * ib;
      gain += 4;
    }
    double* cogging = m + layout.cogging_harmonics_offset();
    for (const int n : layout.harmonics.cogging) {
      cogging[0] = cos_n[n];
      cogging[1] = sin_n[n];
      cogging += 2;
    }
  }
  m[layout.direction_offset()] = d;
}

/// The data part of eq. (31)'s normal matrix, 1/N Σ M Mᵀ, and its right-hand
/// side 1/N Σ M wrenchᵀ (one column per direction), given the hidden layers.
void linear_normal_equations(const CoilSetDataset& data, const PgnnFeatures& f, const PgnnLayout& layout,
                             const double* nonlinear, Eigen::MatrixXd& gram, Eigen::MatrixXd& rhs);

/// RegressorQuality of the linear parameters at the hidden layers in
/// `nonlinear`, each column judged on its own; the direction-dependent
/// force's column only when `direction` is identified.
RegressorQuality linear_regressor_quality(const CoilSetDataset& data, const PgnnFeatures& f, const PgnnLayout& layout,
                                          const double* nonlinear, const DirectionForce& direction);

/// Eq. (31) for one coil set, given the hidden layers in `nonlinear`; writes the
/// three directions' linear parameters (one column per direction).
void ridge_linear(const CoilSetDataset& data, const PgnnFeatures& f, const PgnnLayout& layout, const double* nonlinear,
                  const CoilGain& physics_a, const CoilGain& physics_b, double regularisation,
                  Eigen::Matrix<double, Eigen::Dynamic, 3>& linear);

/// Writes the hidden and linear parameters into the networks of `coil_set`,
/// and C_q into `direction`'s amplitude.
void unpack_parameters(const PgnnLayout& layout, const double* nonlinear,
                       const Eigen::Matrix<double, Eigen::Dynamic, 3>& linear, CoilSetModel& coil_set,
                       DirectionForce& direction);

/// Reads the parameters back from the networks and `direction` (inverse of
/// unpack_parameters).
void pack_parameters(const PgnnLayout& layout, const CoilSetModel& coil_set, const DirectionForce& direction,
                     std::vector<double>& nonlinear, Eigen::Matrix<double, Eigen::Dynamic, 3>& linear);

}  // namespace clm::identification
