#pragma once
// The closed loop around the simulated motor, as the daemon and the
// commissioning tools run it: per control period the reference (now and a
// one-sample preview) and the measured position give the force demand F*_y
// (clm::control::PositionController); a commutation law turns [F*_y, 0, 0]
// into drive setpoints at the measured position — or, in experiment mode, one
// coil set is driven alone with magnitude F*_y and a constant offset Δ (the
// data sets of Algorithms 1 and 2); then command → step → sense. No I/O.

#include <array>
#include <span>
#include <vector>

#include "commutation/commutator.hpp"
#include "daemon/control/position_controller.hpp"
#include "daemon/control/trajectory.hpp"
#include "drivers/sim/motor.hpp"

namespace clm::commission {

/// How the force demand reaches the coil sets.
struct LoopCommutation {
  /// (a) A commutation law (classical, original, PGNN, spline, oracle) that
  /// commutates [F*_y, 0, 0] at the measured position. Must outlive the run.
  const CommutationLaw* law = nullptr;
  /// (b) Experiment mode (when law == nullptr): coil set `experiment_coil_set`
  /// (0-based) gets magnitude F*_y and offset `experiment_delta_rad`, the
  /// others zero.
  int experiment_coil_set = 0;
  double experiment_delta_rad = 0.0;

  static LoopCommutation with_law(const CommutationLaw& commutation_law) { return {&commutation_law, 0, 0.0}; }
  static LoopCommutation experiment(int coil_set, double delta_rad) { return {nullptr, coil_set, delta_rad}; }
};

struct ClosedLoopOptions {
  /// Run this long after the end of the program [s], ≥ 0.
  double extra_time_s = 0.0;
  /// Reset the motor at rest at the program's start position (faults cleared)
  /// before the run; otherwise start from its present state.
  bool reset_motor = true;
};

/// One control period, recorded as a snapshot at its end t_s: the sensor
/// frame at t_s, and the command that was in effect up to t_s (computed at
/// t_s − T from the previous frame). So y_m, the wrench, the setpoints and
/// ia_A/ib_A of one sample belong together (Ψ(Γ(y)T(setpoint), y) = wrench up
/// to noise), and Fy_N − F*_y is the commutation error of that command. The
/// accessors carry the project's CSV column names (t_s, coil_set, delta_rad,
/// magnitude_N, y_m, Fy_N, Fx_N, Tz_Nm, ia_A, ib_A); coil-set arguments are
/// 0-based like the rest of the API.
struct ClosedLoopSample {
  double t_s = 0.0;             ///< time of the snapshot since the start of the run [s]
  double r_m = 0.0;             ///< reference at t_s [m]
  double y_m = 0.0;             ///< measured position at t_s [m]
  double force_demand_N = 0.0;  ///< F*_y in effect (computed at t_s − T) [N]
  Wrench measured = Wrench::Zero();  ///< measured [Fy_N, Fx_N, Tz_Nm]
  Wrench desired = Wrench::Zero();   ///< desired wrench [F*_y, 0, 0] [N, N, N·m]
  /// Experiment mode: the driven coil set, 1-based as the CSV column
  /// coil_set; 0 when a commutation law drives all coil sets.
  int coil_set = 0;
  std::array<DriveSetpoint, kMaxCoilSets> setpoints{};  ///< magnitude_N, delta_rad per coil set
  CurrentVector currents_A;          ///< true applied [ia_A, ib_A] per coil set [A]
  double true_position_m = 0.0;      ///< [m]
  double true_velocity_m_per_s = 0.0;  ///< [m/s]
  std::uint32_t status_word = 0;     ///< sim::DriveStatus::word at t_s

  double Fy_N() const { return measured.x(); }
  double Fx_N() const { return measured.y(); }
  double Tz_Nm() const { return measured.z(); }
  double magnitude_N(int l) const { return setpoints[static_cast<std::size_t>(l)].magnitude_N; }
  double delta_rad(int l) const { return setpoints[static_cast<std::size_t>(l)].delta_rad; }
  double ia_A(int l) const { return currents_A[2 * l]; }
  double ib_A(int l) const { return currents_A[2 * l + 1]; }
};

struct ClosedLoopRecord {
  int coil_sets = 0;
  double period_s = 0.0;
  LoopCommutation commutation;
  std::vector<ClosedLoopSample> samples;
  /// Index of the first sample whose status shows a fault, or −1.
  long first_fault_sample = -1;
  sim::DriveStatus final_status;

  /// Columns for clm::control::commutation_error_mse and the calibration.
  std::vector<Eigen::Vector3d> measured_wrenches() const;
  std::vector<Eigen::Vector3d> desired_wrenches() const;
  std::vector<double> measured_positions_m() const;
  std::vector<double> magnitudes_N(int coil_set) const;  ///< 0-based; throws std::out_of_range
  std::vector<double> driving_forces_N() const;
  std::vector<double> force_demands_N() const;
  std::vector<double> tracking_errors_m() const;  ///< r_m − y_m
  std::vector<control::ReferenceSample> reference(const control::MoveProgram& program) const;
};

/// Runs `program` (plus options.extra_time_s) in closed loop with the
/// controller's period. `controller` is copied and reset. Throws
/// std::invalid_argument if the commutation's coil-set count or the
/// experiment coil set does not fit the motor. The loop itself does not
/// allocate: the record is sized before the first period.
ClosedLoopRecord run_closed_loop(sim::SimulatedMotor& motor, const control::MoveProgram& program,
                                 control::PositionController controller, const LoopCommutation& commutation,
                                 const ClosedLoopOptions& options = {});

}  // namespace clm::commission
