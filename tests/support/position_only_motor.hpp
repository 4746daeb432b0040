#pragma once
// A synthetic motor for the position-based identification's tests, integrated
// here and not by the project's simulator: known mass, viscous friction, one
// direction-dependent force, and a y-row of gains and cogging on a spline
// basis. A PD loop with feedforward tracks two superposed sines; the mechanics
// are integrated in 20 substeps per period, the setpoint held over the period
// after it, the currents commutated from the true position at every substep;
// positions quantised to 0.1 µm. Optionally the drive's compensated current
// loop: the magnitude a setpoint asks for is reached through a first-order
// lag (the substep's exact mean), after a delay of whole substeps, while the
// drive commutates from the true position.

#include <random>
#include <vector>

#include "commutation/bspline.hpp"
#include "commutation/identification/motion_fit.hpp"
#include "commutation/types.hpp"

namespace clm::test {

struct PositionOnlyMotor {
  static constexpr double kPolePitch_m = 0.03;
  static constexpr double kPeriod_s = 1e-3;
  static constexpr int kSubsteps = 20;
  /// The drive's nominal commutation (k̂_d, ζ̂_d).
  static DriveCommutation nominal_drive() { return {60.0, -0.5}; }
  DriveCommutation drive = nominal_drive();
  UniformCubicBasis basis{-0.07, 0.07, 28};  // 5 mm knots
  double mass_kg = 12.0;
  double viscous_N_s_per_m = 30.0;
  double direction_N = 6.0;
  double smoothing_m_per_s = 1e-3;
  double current_loop_Hz = 0.0;  ///< 0: the magnitude follows the setpoint at once
  int delay_substeps = 0;        ///< of kPeriod_s / kSubsteps each
  identification::MotionFit model;  ///< the y-row on `basis`, the form the fit identifies

  /// Random columns (±3 N/A) and cogging (±2 N) on a physics part of k, ζ.
  PositionOnlyMotor(std::mt19937_64& rng, double motor_constant_N_per_A, double phase_offset_rad);

  double force_N(double position_m, const Eigen::Vector2d& currents_A) const;

  /// One run at drive offset `delta_rad`; `magnitude_N` receives each row's setpoint.
  identification::MotionRun run(double delta_rad, double seconds, double phase,
                                std::vector<double>* magnitude_N = nullptr) const;
};

}  // namespace clm::test
