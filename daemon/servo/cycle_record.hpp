#pragma once
// One cycle of the servo loop: the single in-process type for it. The cycle
// fills it, telemetry publishes it as clm_lcm::servo_state_t, the log reader
// and the commissioning read it back. Every field that goes on the wire has
// the name of its servo_state_t field (lcmtypes/servo_state_t.lcm documents
// them); daemon/telemetry/lcm_conversion.hpp holds the one conversion each
// way. Fixed size: the cycle fills it without allocating.

#include <array>
#include <cstdint>

#include "commutation/types.hpp"
#include "daemon/servo/fault.hpp"

namespace clm::servo {

/// The servo's state; values are servo_status_t.STATE_*.
enum class ServoState : std::uint8_t { kDisabled = 0, kEnabled = 1, kFault = 2 };

/// Where homing is (docs/servod.md, "Homing"); values are servo_status_t.HOMING_*.
enum class HomingPhase : std::uint8_t {
  kIdle = 0,
  kFinding = 1,    ///< commutation finding: the loop open, doublets at test phases
  kSearching = 2,  ///< the loop closed, moving at the search velocity, the drive's latch armed
  kStopping = 3,   ///< the event latched: stopping before the position frame moves to it
  kBackingOff = 4, ///< hard_stop: at the stop, moving back off it before stopping
  /// reference_switch: the switch was active at the start; moving out of it
  /// (the latch not armed), then stopping and searching again from outside.
  kLeavingSwitch = 5,
};

/// The commutation the cycle uses; values are servo_state_t.COMMUTATION_*.
enum class CommutationMode : std::uint8_t {
  kOriginal = 0,    ///< the drive's own fixed law, uncalibrated
  kClassical = 1,   ///< classical law (12) with calibrated constants
  kPgnn = 2,        ///< inverse (37) of the PGNN model
  kSpline = 3,      ///< inverse (37) of the spline model
  kOracle = 4,      ///< inverse of the simulator's static truth (simulation only)
  kExperiment = 5,  ///< one coil set driven with F* and a constant offset Δ (Algorithms 1, 2)
};
inline constexpr int kCommutationModes = 6;
const char* name(CommutationMode mode) noexcept;
const char* name(ServoState state) noexcept;

/// What one cycle did. Forces are [Fy, Fx, Tz]: driving force, out-of-plane
/// force, torque about z.
struct CycleRecord {
  std::int64_t utime = 0;         ///< wall-clock time [µs since the UNIX epoch]; 0 = stamp at publication
  std::int64_t cycle = 0;         ///< cycle counter since the daemon started
  double t_s = 0.0;               ///< time since the daemon started [s]
  double r_m = 0.0;               ///< reference position [m]
  double r_dot_m_per_s = 0.0;     ///< reference velocity [m/s]
  double r_ddot_m_per_s2 = 0.0;   ///< reference acceleration [m/s²]
  double y_m = 0.0;               ///< measured position [m]
  double e_m = 0.0;               ///< tracking error r_m − y_m [m]
  double F_star_N = 0.0;          ///< force demand F* = u_fb_N + u_ff_N, after the force limit [N]
  double u_fb_N = 0.0;            ///< feedback part of F* [N]
  double u_ff_N = 0.0;            ///< feedforward part of F*, eq. (40) [N]
  double Fy_star_N = 0.0;         ///< desired driving force [N]
  double Fx_star_N = 0.0;         ///< desired out-of-plane force [N]
  double Tz_star_Nm = 0.0;        ///< desired torque about z [N m]
  bool force_measured = false;    ///< Fy_N, Fx_N, Tz_Nm are this cycle's force-sensor frame (else 0)
  double Fy_N = 0.0;              ///< measured driving force (force sensor) [N]
  double Fx_N = 0.0;              ///< measured out-of-plane force [N]
  double Tz_Nm = 0.0;             ///< measured torque about z [N m]
  CommutationMode commutation = CommutationMode::kOriginal;
  int coil_set = 0;               ///< experiment: driven coil set 1..coil_sets, 0 = none
  double delta_rad = 0.0;         ///< experiment: phase offset [rad], 0 = none
  int coil_sets = 0;              ///< L, 0..kMaxCoilSets; the arrays' first L entries are meaningful
  std::array<double, kMaxCoilSets> magnitude_N{};         ///< magnitude setpoint of each coil set, eq. (18) [N]
  std::array<double, kMaxCoilSets> setpoint_delta_rad{};  ///< phase-offset setpoint of each coil set, eq. (18) [rad]
  std::array<double, kMaxCoilSets> ia_A{};                ///< commanded star current i_a of each coil set [A] (sent with phase_current)
  std::array<double, kMaxCoilSets> ib_A{};                ///< commanded star current i_b of each coil set [A] (sent with phase_current)
  bool damping_engaged = false;   ///< the drive's short-circuit damping is engaged
  double current_square_sum_A2 = 0.0;  ///< Σ i_a² + i_b² + i_c² over all coil sets [A²]
  bool force_limited = false;     ///< |F*| was at the force limit in this cycle
  ServoState state = ServoState::kDisabled;
  bool program_running = false;   ///< a motion program (or move_to) runs in this cycle
  double program_time_s = 0.0;    ///< time into the running program [s], 0 when none
  /// What the setpoint frames carried: magnitude_N and setpoint_delta_rad
  /// (magnitude_phase), or ia_A and ib_A as they are (phase_current; the
  /// magnitudes and offsets are then the equivalent eq. (39) values, not sent).
  /// With drive.current_loop the frames carry them corrected for the drive's
  /// current loop (docs/commutation.md, "The drive's current loop").
  DriveProfile drive_profile = DriveProfile::kMagnitudePhase;

  // In process only, not in servo_state_t (servo_status_t carries the fault);
  // the conversion from servo_state_t leaves them at their defaults.
  Fault fault = Fault::kNone;
  std::uint16_t drive_status_word = 0;
  bool stopping = false;          ///< a stop, quick stop or fault reaction is under way
  bool restricted = false;        ///< restricted mode: only a slow move back inside the soft limits
};

}  // namespace clm::servo
