#pragma once
// The true electromagnetic part Ψ of the simulated motor (paper eq. 22 with a
// truth richer than any model of the library):
//
//   F = Σ_l K^l(y)·[i_a^l, i_b^l] + F_cog(y) + C·tanh(v/v_c).
//
// K^l is eq. (7) reduced to the two star currents (i_c = −i_a − i_b), with
// per-phase force functions
//   s_p = sin(η_p) + h5·sin(5η_p + ψ5) + h7·sin(7η_p + ψ7),   (row y)
//   c_p = cos(η_p) + h5·cos(5η_p + ψ5) + h7·cos(7η_p + ψ7),   (rows x, z)
//   η_p = 2πy/d_m + ζ^l + β(y + d^l) + {0, +2π/3, −2π/3}_p,
// and column p = (2/3)·k^l·(1 + a(y + d^l))·(1 + ε_p^l)·[s_p, μ·c_p, d^l·μ·c_p + e^l·s_p].
// F_cog is periodic cogging + a slow random function + a cable spring. The
// force is linear in the currents for every position (Lorentz, Assumption 2.1).

#include <array>
#include <span>
#include <vector>

#include "commutation/bspline.hpp"
#include "commutation/types.hpp"
#include "drivers/sim/parameters.hpp"

namespace clm::sim {

/// A drawn SmoothVariation: a uniform cubic B-spline (the basis of
/// clm::UniformCubicBasis) with knot spacing ≤ ℓ over [start − ℓ, end + ℓ],
/// constant beyond, plus the linear trend about the centre of [start, end].
/// One component, or three sharing the knots with independent coefficients
/// (the wrench form). Evaluation does not allocate.
class SmoothRandomFunction {
 public:
  SmoothRandomFunction() = default;  ///< identically zero
  /// One component; coefficients drawn from a stream seeded with `seed`.
  SmoothRandomFunction(const SmoothVariation& variation, double track_start_m, double track_end_m,
                       std::uint64_t seed);
  /// Three components with RMS rms[q] and no trend.
  SmoothRandomFunction(const Wrench& rms, double correlation_length_m, double track_start_m, double track_end_m,
                       std::uint64_t seed);

  /// Value of the first component.
  double operator()(double track_position_m) const noexcept;
  /// All three components (the wrench form); a one-component function fills
  /// the first only.
  Wrench wrench(double track_position_m) const noexcept;

  const UniformCubicBasis& basis() const noexcept { return basis_; }
  /// Coefficient j of component c (0 if none were drawn).
  double coefficient(int component, int j) const noexcept {
    return components_ == 0 ? 0.0 : coefficients_[static_cast<std::size_t>(j * components_ + component)];
  }

 private:
  void draw(std::span<const double> rms, double correlation_length_m, double track_start_m, double track_end_m,
            std::uint64_t seed);
  /// First basis index and the four basis values at a position; as
  /// UniformCubicBasis::evaluate, with the spacing inverted once.
  int span(double track_position_m, double value[4]) const noexcept;

  UniformCubicBasis basis_;
  double inverse_spacing_per_m_ = 0.0;
  int components_ = 0;
  std::vector<double> coefficients_;  ///< [basis index][component]
  double slope_per_m_ = 0.0;
  double centre_m_ = 0.0;
};

class ElectromagneticTruth {
 public:
  /// Validates `parameters` (throws ParameterError) and draws every random
  /// parasitic from `parameters.seed`. The magnet track varies over the
  /// positions the coil sets can reach when the translator moves in
  /// [travel_min_m, travel_max_m], with one correlation length of margin;
  /// beyond that it stays constant.
  ElectromagneticTruth(const ElectromagneticParameters& parameters, double travel_min_m, double travel_max_m);

  int coil_sets() const noexcept { return count_; }
  double pole_pitch_m() const noexcept { return parameters_.pole_pitch_m; }
  const ElectromagneticParameters& parameters() const noexcept { return parameters_; }

  /// Everything of the truth that depends on the position alone, at one
  /// position: the phase functions of every coil set and F_cog. The force
  /// functions below that take one give the bits of those that take the
  /// position (the same operations); a caller that evaluates the force
  /// several times at one position computes it once.
  struct PositionTerms {
    double position_m = 0.0;
    /// s_p and c_p times (2/3)·k^l·(1 + a)·g_p, per coil set and phase (phase_functions).
    std::array<std::array<double, 3>, kMaxCoilSets> s{};
    std::array<std::array<double, 3>, kMaxCoilSets> c{};
    Wrench cogging_N_N_Nm = Wrench::Zero();
  };
  void position_terms(double position_m, PositionTerms& terms) const noexcept;

  /// K^l(y) on [i_a, i_b] [N/A, N/A, N·m/A], coil_set in 0..L−1.
  CoilGain gain(int coil_set, double position_m) const noexcept;
  /// [K^1(y), ..., K^L(y)], 3 × 2L.
  void stacked_gain(double position_m, StackedGain& gain) const noexcept;
  /// Static cogging and cable force F_cog(y) [N, N, N·m].
  Wrench cogging(double position_m) const noexcept;
  /// Direction-dependent force C·tanh(v/v_c) [N, N, N·m].
  Wrench direction_dependent(double velocity_m_per_s) const noexcept;
  /// Its tanh's argument v/v_c, for a caller that evaluates the tanh itself
  /// (with others, in one elementary::tanh_array call).
  double direction_ratio(double velocity_m_per_s) const noexcept {
    return velocity_m_per_s / parameters_.direction_smoothing_velocity_m_per_s;
  }
  /// The whole wrench for currents [i_a^1, i_b^1, ...] (2L entries) [N, N, N·m].
  Wrench wrench(double position_m, double velocity_m_per_s, const CurrentVector& currents_A) const noexcept;
  Wrench wrench(const PositionTerms& terms, double velocity_m_per_s, const CurrentVector& currents_A) const noexcept;
  /// Its first component F_y alone [N] (what the mechanics needs, cheaper).
  double driving_force_N(double position_m, double velocity_m_per_s, const CurrentVector& currents_A) const noexcept;
  /// The same from the position terms and direction_tanh = tanh(direction_ratio(v)).
  double driving_force_N(const PositionTerms& terms, double direction_tanh,
                         const CurrentVector& currents_A) const noexcept;

  /// Drawn parasitics, for reports and tests.
  double magnet_intensity(double track_position_m) const noexcept { return intensity_(track_position_m); }
  double magnet_orientation_rad(double track_position_m) const noexcept { return orientation_(track_position_m); }
  /// 1 + ε_p of coil set l, phase p ∈ {0: a, 1: b, 2: c}.
  double phase_gain(int coil_set, int phase) const noexcept {
    return phase_gain_[static_cast<std::size_t>(coil_set)][static_cast<std::size_t>(phase)];
  }

 private:
  struct Rotation {
    double cos = 1.0;
    double sin = 0.0;
  };
  /// Per-phase force functions s_p (row y) and c_p (rows x, z) of coil set l
  /// times (2/3)·k^l·(1 + a)·g_p.
  void phase_functions(int coil_set, double position_m, double s[3], double c[3]) const noexcept;
  /// K^l from its phase functions.
  CoilGain gain(int coil_set, const double s[3], const double c[3]) const noexcept;

  ElectromagneticParameters parameters_;
  int count_ = 0;
  std::array<std::array<double, 3>, kMaxCoilSets> phase_gain_{};
  // e^{i·n·φ_p + i·ψ_n} for n = 5, 7 and the three phases.
  std::array<Rotation, 3> fifth_rotation_{};
  std::array<Rotation, 3> seventh_rotation_{};
  SmoothRandomFunction intensity_;
  SmoothRandomFunction orientation_;
  // Periodic cogging per harmonic and axis as A·cos φ, A·sin φ.
  std::vector<int> cogging_order_;
  std::vector<Wrench> cogging_cos_;
  std::vector<Wrench> cogging_sin_;
  int max_cogging_order_ = 0;
  SmoothRandomFunction cogging_slow_;
};

}  // namespace clm::sim
