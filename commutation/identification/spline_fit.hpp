#pragma once
// The spline model class of one coil set: K̂ and F̂_cog on a uniform cubic
// B-spline basis, fitted as one regularised linear least-squares problem per
// direction, pulled towards the physics-only fit. No I/O.

#include <Eigen/Core>

#include "commutation/identification/dataset.hpp"
#include "commutation/identification/report.hpp"
#include "commutation/model.hpp"

namespace clm::identification {

struct SplineOptions {
  double knot_spacing_m = 0.0;  ///< 0: an eighth of the pole pitch
  double smoothing = 1e-6;      ///< weight of the squared second differences of the coefficients
  double regularisation = 0.1;  ///< Λ pulling A, B towards the physics-only fit
  /// v_c of the direction-dependent force C·tanh(ẏ/v_c) identified beside
  /// the model (Remark 5.1); 0, or data without velocities: none.
  double direction_smoothing_m_per_s = 0.0;
};

/// Spline model of one coil set: K̂ = A cos + B sin + Σ_j b_j(y)·[C_a,j, C_b,j],
/// F̂_cog = Σ_j b_j(y)·G_j on `basis`, solved as one regularised linear
/// least-squares problem per direction. Throws std::invalid_argument for too
/// few samples, negative options or a singular problem.
CoilSetModel identify_spline_coil_set(const CoilSetDataset& training, const CoilSetDataset& validation,
                                      double pole_pitch_m, const UniformCubicBasis& basis,
                                      const SplineOptions& options, IdentificationReport& report);

/// Adds weight·Σ_j (c_j − 2c_{j+1} + c_{j+2})² to `gram` for each of `blocks`
/// consecutive runs of `n` spline coefficients starting at column `first`:
/// the roughness penalty of the spline model's coefficient rows.
void add_roughness_penalty(Eigen::MatrixXd& gram, int first, int n, int blocks, double weight);

/// Knot grid covering `position_m` with spacing options.knot_spacing_m (or d_m/8).
UniformCubicBasis spline_basis_for(const Eigen::VectorXd& position_m, double pole_pitch_m, const SplineOptions& options);

}  // namespace clm::identification
