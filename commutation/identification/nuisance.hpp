#pragma once
// Nuisance terms of identification (docs/commutation.md, "Nuisance terms"):
// forces the force sensor measures that no static commutation can act on.
//  - The direction-dependent force C·tanh(ẏ/v_c) of Remark 5.1 (cable-slab
//    hysteresis, eddy-current drag), identified per direction beside each
//    model so that least squares cannot fold it into K̂ and F̂_cog.
//  - A constant offset of the sensor's driving-direction reading, identified
//    from the mechanics: a translator that stands still or moves as Newton's
//    law says carries no unexplained constant force.
// Both are reported and never enter the commutation law (eq. 37 stays static).
// No I/O.

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "commutation/elementary.hpp"
#include "commutation/identification/dataset.hpp"

namespace clm::identification {

/// C·tanh(ẏ/v_c) per direction [F_y N, F_x N, T_z N·m] (Remark 5.1).
struct DirectionForce {
  Eigen::Vector3d amplitude = Eigen::Vector3d::Zero();  ///< C [N, N, N·m]; negative opposes the motion
  double smoothing_velocity_m_per_s = 0.0;              ///< v_c [m/s]; 0: no term (data without velocity)

  /// tanh(ẏ/v_c), the regressor of C; 0 without a term.
  double feature(double velocity_m_per_s) const {
    return smoothing_velocity_m_per_s > 0.0 ? elementary::tanh(velocity_m_per_s / smoothing_velocity_m_per_s) : 0.0;
  }
  bool identified() const { return smoothing_velocity_m_per_s > 0.0; }
};

/// v_c values tried, in m/s: from below the velocity resolution of a 0.1 µm
/// encoder at 1 kHz to well above the creep speeds of a dwell. The one whose
/// spline fit predicts the held-out blocks best is kept.
inline constexpr double kDirectionSmoothingGrid_m_per_s[] = {5e-4, 1e-3, 2e-3, 4e-3, 8e-3};

/// d(values)/dt at every sample by central differences (one-sided at the
/// ends), within contiguous stretches: a time step that is not positive or
/// exceeds 1.5× the median step starts a new stretch (the gap between two
/// experiments). A stretch of one sample gets 0. Throws std::invalid_argument
/// for different lengths or non-finite values.
Eigen::VectorXd differentiate(const Eigen::VectorXd& time_s, const Eigen::VectorXd& values);

/// The driving-direction offset of the force sensor, from the mechanics of
/// the translator: F_y,measured = m·ÿ + f_v·ẏ + f_c·tanh(ẏ/v_s) + offset,
/// least squares over every sample (the sensor measures every force of the
/// electromagnetic part, the direction-dependent one included; bearing
/// friction acts between translator and base). Dwells pin the offset:
/// standing still, the electromagnetic force balances a friction of zero.
struct DrivingOffsetFit {
  double offset_N = 0.0;
  double mass_kg = 0.0;
  double viscous_N_s_per_m = 0.0;
  double coulomb_N = 0.0;
  double friction_smoothing_m_per_s = 0.0;  ///< v_s of the best fit, from kDirectionSmoothingGrid_m_per_s
  double residual_rms_N = 0.0;
  double condition = 0.0;  ///< of the column-scaled regressor matrix
  Eigen::Index samples = 0;
};

/// One contiguous recording: times, positions and the measured F_y.
struct MotionRecord {
  Eigen::VectorXd time_s;
  Eigen::VectorXd position_m;
  Eigen::VectorXd force_N;
};

/// Fits DrivingOffsetFit over `records` (velocity and acceleration by
/// `differentiate`). Throws std::invalid_argument for fewer than 10 samples
/// or regressors that do not excite mass, friction and offset apart.
DrivingOffsetFit fit_driving_sensor_offset(const std::vector<MotionRecord>& records);

/// How well `data` tells the direction-dependent force from a gain: the
/// variance inflation factor 1/(1 − R²) of tanh(ẏ/v_c) regressed on the
/// physics-only regressors [cos θ·i_a, cos θ·i_b, sin θ·i_a, sin θ·i_b, 1].
/// When the current is nearly ±I in the two directions of motion (one speed,
/// friction-dominated), a gain error mimics C·sign(ẏ) and the factor grows
/// without bound. Infinite without velocities or with a constant feature.
double direction_force_inflation(const CoilSetDataset& data, double pole_pitch_m, double direction_smoothing_m_per_s);

/// Above this factor the direction-dependent force is not identified: the
/// common bound for a regressor that others explain four fifths of. Against
/// the physics-only regressors the factor understates the collinearity with
/// a model whose gains vary along the stroke, hence the stricter of the two
/// usual bounds. Measured (docs/commutation.md, "Nuisance terms"): 1.7–2.9 on
/// programs/identification.yaml for the three simulated motors, 10.4 on
/// Fig. 8 and 9.2 on a single stroke, where C came out wrong.
inline constexpr double kMaxDirectionForceInflation = 5.0;

}  // namespace clm::identification
