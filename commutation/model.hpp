#pragma once
// Invertible models of the electromagnetic part, eq. (22)-(24) and (35):
//   F̂ = Σ_l K̂^l(y)·i^l + (1/L)·Σ_l F̂_cog^l(y),
//   K̂^l(y) = A^l·cos(2πy/d_m) + B^l·sin(2πy/d_m) + [g_a^l(y), g_b^l(y)],
// where the column functions g and the cogging F̂_cog are either neural
// networks (PGNN, eq. 24-25) or cubic B-splines (the spline model class).
// With zero networks the model is the classical one (7). A PGNN's physics
// part may also carry harmonics of the electrical angle: the field harmonics
// in K̂ and a Fourier series of the cogging (HarmonicOrders below;
// docs/commutation.md, "Harmonics in the physics part").

#include <algorithm>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "commutation/bspline.hpp"
#include "commutation/classical.hpp"
#include "commutation/network.hpp"
#include "commutation/types.hpp"

namespace clm {

enum class ModelKind { kPgnn, kSpline };

/// Network input y_n = (y − offset_m)/scale_m (docs/commutation.md §7).
struct PositionNormalisation {
  double offset_m = 0.0;
  double scale_m = 1.0;
  double apply(double position_m) const { return (position_m - offset_m) / scale_m; }
};

/// Highest harmonic order of the electrical angle a model may carry.
inline constexpr int kMaxHarmonicOrder = 16;

/// cos(nθ) and sin(nθ) for n = 0..max_order into cos_n[n], sin_n[n], from
/// cos θ and sin θ by the angle-addition recurrence, so that identification
/// and the cycle compute bit-identical values. No allocation.
inline void angle_harmonics(double cos_theta, double sin_theta, int max_order, double* cos_n, double* sin_n) noexcept {
  cos_n[0] = 1.0;
  sin_n[0] = 0.0;
  for (int n = 1; n <= max_order; ++n) {
    cos_n[n] = cos_n[n - 1] * cos_theta - sin_n[n - 1] * sin_theta;
    sin_n[n] = sin_n[n - 1] * cos_theta + cos_n[n - 1] * sin_theta;
  }
}

/// Harmonic orders of the electrical angle θ = 2πy/d_m that a PGNN's physics
/// part carries beside A·cos θ + B·sin θ: in K̂, Σ_n C_n·cos nθ + S_n·sin nθ
/// (the magnets' field harmonics: a three-phase winding in star sees the
/// orders 6k ± 1), and in the cogging Σ_m c_m·cos mθ + s_m·sin mθ (forces
/// periodic in the pole pitch). Ascending, distinct; gain orders 2..,
/// cogging orders 1.., both at most kMaxHarmonicOrder. Empty: the paper's.
struct HarmonicOrders {
  std::vector<int> gain;
  std::vector<int> cogging;
  bool empty() const { return gain.empty() && cogging.empty(); }
  int max_order() const {
    return std::max(gain.empty() ? 0 : gain.back(), cogging.empty() ? 0 : cogging.back());
  }
  bool operator==(const HarmonicOrders&) const = default;
};

/// Lowest orders: in K̂ 2 (order 1 is A·cos θ + B·sin θ), in the cogging 1.
inline constexpr int kLowestGainHarmonic = 2;
inline constexpr int kLowestCoggingHarmonic = 1;

/// Empty when `orders` are ascending, distinct and within
/// lowest..kMaxHarmonicOrder; otherwise what is wrong.
std::string harmonic_orders_error(const std::vector<int>& orders, int lowest);

/// Spline coefficients of a column function or the cogging: 3 × basis size.
using SplineCoefficients = Eigen::Matrix<double, 3, Eigen::Dynamic>;

struct CoilSetModel {
  CoilGain a_N_per_A = CoilGain::Zero();  ///< A^l of eq. (24)
  CoilGain b_N_per_A = CoilGain::Zero();  ///< B^l of eq. (24)
  // ModelKind::kPgnn
  Network column_a;  ///< f_NN(θ_1^l, ·) [N/A]
  Network column_b;  ///< f_NN(θ_2^l, ·) [N/A]
  Network cogging;   ///< f_NN(φ^l, ·) [N, N, N·m]
  /// Physics-part harmonics (ElectromagneticModel::harmonics): per gain
  /// order the four columns [cos·i_a, cos·i_b, sin·i_a, sin·i_b], 3 × 4·orders
  /// [N/A]; per cogging order [cos, sin], 3 × 2·orders [N, N, N·m].
  Eigen::Matrix<double, 3, Eigen::Dynamic> gain_harmonics_N_per_A;
  Eigen::Matrix<double, 3, Eigen::Dynamic> cogging_harmonics_N;
  // ModelKind::kSpline
  SplineCoefficients column_a_spline;
  SplineCoefficients column_b_spline;
  SplineCoefficients cogging_spline;
};

/// Thrown when a model is inconsistent; the message names the part.
class ModelError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

struct ElectromagneticModel {
  ModelKind kind = ModelKind::kPgnn;
  double pole_pitch_m = 0.0;               ///< d_m
  PositionNormalisation normalisation;     ///< PGNN network input
  HarmonicOrders harmonics;                ///< PGNN physics-part harmonics (empty: the paper's)
  UniformCubicBasis spline_basis;          ///< spline model knot grid
  std::vector<CoilSetModel> coil_sets;

  int coil_set_count() const { return static_cast<int>(coil_sets.size()); }

  /// K̂^l(y) and F̂_cog^l(y) of one coil set (eq. 24). No allocation.
  void evaluate_coil_set(int coil_set, double position_m, CoilGain& gain, Wrench& cogging) const noexcept;

  /// Stacked K̂(y) (3 × 2L) and the averaged cogging of eq. (35). No allocation.
  void evaluate(double position_m, StackedGain& gain, Wrench& cogging) const noexcept;

  /// F̂ of eq. (35) for currents [i_a^1, i_b^1, ...]. No allocation.
  Wrench predict(double position_m, const CurrentVector& currents_A) const noexcept;

  /// Throws ModelError unless dimensions agree, every parameter is finite,
  /// 1 ≤ L ≤ kMaxCoilSets and the harmonic orders are valid (a PGNN's only).
  void validate() const;
};

/// Adds the physics-part harmonics of one coil set to its gain and cogging,
/// given cos(nθ), sin(nθ) up to orders.max_order() (angle_harmonics). No
/// allocation.
void add_physics_harmonics(const HarmonicOrders& orders, const CoilSetModel& part, const double* cos_n,
                           const double* sin_n, CoilGain& gain, Wrench& cogging) noexcept;

/// All networks of a PGNN model with one hidden layer each, fused into one
/// hidden vector so that the cycle evaluates every tanh in a single vectorised
/// pass (the paper's architecture). Built once from a model; evaluate() gives
/// the same K̂ and averaged cogging as ElectromagneticModel::evaluate.
class FusedPgnnEvaluator {
 public:
  /// True when every network of every coil set has exactly one hidden layer.
  static bool supports(const ElectromagneticModel& model);
  explicit FusedPgnnEvaluator(const ElectromagneticModel& model);
  void evaluate(double position_m, StackedGain& gain, Wrench& cogging) const noexcept;

 private:
  struct Output {
    int first = 0;   // offset of this network's neurons in the hidden vector
    int width = 0;
    double bias[3] = {0.0, 0.0, 0.0};
  };
  const ElectromagneticModel* model_;
  // Hidden layers of all networks, one neuron after the other, padded with
  // zero neurons to a multiple of 4 (the lanes of elementary::tanh_array).
  std::vector<double> input_weight_;
  std::vector<double> input_bias_;
  mutable std::vector<double> hidden_;  // scratch, sized at construction
  // Output weights neuron by neuron: 4 values per hidden neuron (the 3 outputs
  // and a zero) at 4·(neuron index), so that each neuron's contribution is two
  // 2-lane multiply-adds.
  std::vector<double> output_weights_;
  std::vector<Output> outputs_;  // 3 per coil set: column_a, column_b, cogging
};

/// The classical model (7) as a PGNN with zero networks of the given hidden sizes
/// (empty: no networks at all).
ElectromagneticModel make_classical_model(double pole_pitch_m, std::span<const ClassicalCoilSet> coil_sets,
                                          const std::vector<int>& column_hidden_sizes = {},
                                          const std::vector<int>& cogging_hidden_sizes = {});

}  // namespace clm
