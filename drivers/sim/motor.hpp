#pragma once
// SimulatedMotor: the plant (true electromagnetics + rigid translator on a
// bearing), the drive with its fixed classical commutation, current limit and
// setpoint watchdog, and the encoder and force/torque sensor. No I/O.
//
// One control period is: command(setpoints, enable) → step(period_s) →
// sense(). command(), step() and sense() do not allocate, lock or throw.

#include <cmath>
#include <cstdint>
#include <span>

#include "commutation/types.hpp"
#include "drivers/sim/current_loop.hpp"
#include "drivers/sim/electromagnetics.hpp"
#include "drivers/sim/parameters.hpp"
#include "drivers/sim/random.hpp"

namespace clm::sim {

/// Bits of DriveStatus::word. "Latched" bits stay set until clear_fault().
enum DriveStatusBit : std::uint32_t {
  /// The drive applies current: the last accepted command asked for enable
  /// and no fault is latched.
  kStatusEnabled = 1u << 0,
  /// Latched: a fault stopped the current (any of the bits 2, 4, 5 below, or
  /// alone for a fault inside the drive: latch_internal_fault()).
  /// Setpoints are dropped; after clear_fault() a command with enable = true
  /// is needed to drive current again.
  kStatusFault = 1u << 1,
  /// Latched: no accepted command for watchdog_timeout_s while enabled.
  kStatusWatchdog = 1u << 2,
  /// Not latched: during the last step() at least one substep limited the
  /// current of at least one coil set (see DriveParameters::phase_current_limit_A).
  kStatusCurrentLimited = 1u << 3,
  /// The translator hit an end stop (moved into it; latched, and the drive
  /// faults), or is at or beyond a limit switch
  /// (MechanicsParameters::limit_switch_min_m, _max_m; while it is there,
  /// without a fault of the drive's own).
  kStatusEndStop = 1u << 4,
  /// Latched: a command had the wrong number of setpoints or a non-finite value.
  kStatusInvalidSetpoint = 1u << 5,
  /// Not latched: the position latch (set_latch) caught its event since it
  /// was armed; clears when it is disarmed.
  kStatusLatched = 1u << 6,
  /// Not latched: the reference switch is active now
  /// (SensorParameters::reference_switch_min_m, _max_m, on the read head's true position).
  kStatusReferenceSwitch = 1u << 7,
};

/// What the drive's position latch waits for (a touch probe's trigger).
enum class LatchSource {
  kIndex,            ///< the encoder's next index mark (SensorParameters::index_pitch_m)
  kReferenceSwitch,  ///< the reference switch becoming active
};

struct DriveStatus {
  std::uint32_t word = 0;
  bool has(DriveStatusBit bit) const noexcept { return (word & bit) != 0; }
  bool enabled() const noexcept { return has(kStatusEnabled); }
  bool fault() const noexcept { return has(kStatusFault); }
  bool watchdog() const noexcept { return has(kStatusWatchdog); }
  bool current_limited() const noexcept { return has(kStatusCurrentLimited); }
  bool end_stop() const noexcept { return has(kStatusEndStop); }
  bool invalid_setpoint() const noexcept { return has(kStatusInvalidSetpoint); }
  bool latched() const noexcept { return has(kStatusLatched); }
  bool reference_switch() const noexcept { return has(kStatusReferenceSwitch); }
};

enum class CommandResult {
  kAccepted,
  kWrongCoilSetCount,  ///< setpoints.size() != L: rejected, fault latched
  kNotFinite,          ///< a magnitude, offset or current is NaN/inf: rejected, fault latched
  kWrongProfile,       ///< a setpoint of the other drive profile (DriveParameters::profile): rejected, fault latched
};

enum class StepResult {
  kOk,
  kInvalidPeriod,  ///< period_s not finite, ≤ 0, or over 10^7 substeps: nothing happened
};

/// One sample of the sensors, taken by sense().
struct SensorFrame {
  double time_s = 0.0;      ///< simulation time of the sample [s]
  /// encoder: the read head's true position encoder_delay_s ago, plus the
  /// interpolation error and noise, quantised [m]
  double position_m = 0.0;
  /// Force/torque sensor in the translator: the electromagnetic wrench
  /// (Σ K^l i^l + F_cog + direction-dependent term) + bias + noise. Bearing
  /// friction is not seen. [N, N, N·m]
  Wrench wrench = Wrench::Zero();
};

/// The exact state, for tests and reports.
struct TruthState {
  double time_s = 0.0;
  double position_m = 0.0;        ///< the motor side, where the coils' force acts [m]
  double velocity_m_per_s = 0.0;  ///< of the motor side [m/s]
  /// The encoder's read head (the other side of the flexible mode; the
  /// motor side's for a rigid translator) [m], [m/s].
  double encoder_side_position_m = 0.0;
  double encoder_side_velocity_m_per_s = 0.0;
  /// The band-limited disturbance force acting now (ForceDisturbanceParameters) [N].
  double disturbance_N = 0.0;
  /// Phase currents [i_a^1, i_b^1, ...] in the windings now (the current
  /// loop's, after the current limit of their setpoints); i_c = −i_a − i_b [A].
  CurrentVector currents_A;
  /// Electromagnetic wrench produced now, without sensor bias and noise [N, N, N·m].
  Wrench wrench = Wrench::Zero();
  /// What the setpoints in effect during the last step() made over it: the
  /// wrench of the windings' mean currents at the translator's mean
  /// position over its substeps, without the direction-dependent force
  /// (what the commutation acts on). The step's mean wrench to second order
  /// in the motion within it; with a current loop or a setpoint delay, the
  /// force a cycle's setpoints made, where `wrench` is the force at its end
  /// [N, N, N·m]. Before any step: `wrench` without the direction-dependent force.
  Wrench step_wrench = Wrench::Zero();
  /// Bearing friction acting now (not seen by the force sensor) [N].
  double friction_N = 0.0;
  /// Number of impacts on an end stop since reset(), and the speed of the last [m/s].
  int end_stop_collisions = 0;
  double last_impact_speed_m_per_s = 0.0;
  /// Substeps in which the current limit acted, since reset().
  long current_limited_substeps = 0;
  /// The encoder's reading less the read head's true position: the
  /// incremental encoder's power-up offset (SensorParameters) [m].
  double encoder_offset_m = 0.0;
};

class SimulatedMotor {
 public:
  /// Validates `parameters` (throws ParameterError), draws the truth and
  /// starts at rest at the centre of the stroke with the drive disabled.
  explicit SimulatedMotor(const MotorParameters& parameters);

  /// A fresh setpoint per coil set (feeds the watchdog); the drive applies it
  /// at once. enable = false stops the current. Rejected commands latch
  /// kStatusInvalidSetpoint and a fault. While a fault is latched, accepted
  /// commands drive no current (see clear_fault()).
  /// Profile magnitude_phase only (kWrongProfile otherwise).
  CommandResult command(std::span<const DriveSetpoint> setpoints, bool enable) noexcept;
  /// Profile phase_current only (kWrongProfile otherwise): the phase currents
  /// [i_a, i_b] per coil set, applied as they are in every substep until the
  /// next command (the drive's current loop is taken as ideal, as with the
  /// other profile), subject to the same current limit, watchdog and faults.
  CommandResult command_currents(std::span<const PhaseCurrentSetpoint> currents, bool enable) noexcept;

  /// Advances the simulation by `period_s` in n = max(10, ⌈period_s/h⌉) equal
  /// substeps. In every substep the drive takes the setpoints whose delay
  /// has passed, computes the phase current setpoints from the true position
  /// (eq. 18/19; profile phase_current: the commanded currents), applies the
  /// current limit and the watchdog, its current loop drives the windings
  /// (at once when ideal), and the translator (one mass, or two with the
  /// flexible mode) is integrated with semi-implicit Euler.
  StepResult step(double period_s) noexcept;

  /// Samples the encoder and the force/torque sensor at the current time.
  SensorFrame sense() noexcept;

  DriveStatus status() const noexcept;
  /// Clears the latched bits. The drive stays disabled with zero setpoints
  /// until the next command with enable = true.
  void clear_fault() noexcept;
  /// A fault inside the drive (as overtemperature or a short would be), for
  /// fault injection: kStatusFault latches alone and the current stops now.
  void latch_internal_fault() noexcept;

  TruthState truth() const noexcept;

  /// The drive's position latch (what CiA 402 calls a touch probe): armed,
  /// it latches the encoder's reading at the first event of `source` the
  /// read head passes, once, and reports kStatusLatched until disarmed.
  /// Arming again after a disarm waits for a new event. The reading is the
  /// encoder's (its power-up offset included) at the event's position,
  /// without noise: the drive samples its counter on the edge.
  void set_latch(bool armed, LatchSource source) noexcept;
  /// True once per latch, in the first call after it happened, with the
  /// latched reading [m]: what the drive sends in its latch frame.
  bool take_latch(double& position_m) noexcept;

  /// An external force along y on the translator [N] from now on (a hand, a
  /// cable, an obstacle), until set again; 0 removes it. Not seen by the
  /// force sensor, which measures the coils' wrench. Non-finite values are
  /// taken as 0. reset() removes it.
  void set_disturbance_force_N(double force_N) noexcept {
    disturbance_force_N_ = std::isfinite(force_N) ? force_N : 0.0;
  }

  /// A payload mounted on the translator, on the motor's side of a flexible
  /// mode (a tool, a sample, a test mass) [kg], from now on and across
  /// reset(), until set again; 0 removes it. Not seen by the force sensor
  /// (it measures the coils' wrench); what a known payload changes in the
  /// motion gives the translator's mass without one (docs/commissioning.md,
  /// "The force scale from a known payload"). Throws ParameterError for a
  /// payload negative, not finite, or above kMaxPayloadRatio times the
  /// translator's mass.
  void set_payload_kg(double payload_kg);
  double payload_kg() const noexcept { return payload_kg_; }
  static constexpr double kMaxPayloadRatio = 10.0;

  /// Restarts at time 0 at `position_m` with `velocity_m_per_s`, drive
  /// disabled, faults and counters cleared. The measurement noise stream is
  /// not rewound (a new SimulatedMotor reproduces a run bit for bit). Throws
  /// ParameterError for a position outside the end stops.
  void reset(double position_m, double velocity_m_per_s = 0.0);

  /// The translator moved to `position_m` at `velocity_m_per_s` by an
  /// outside force (a push, a collision) at this instant: the drive, its
  /// faults, the time and the counters are kept, the encoder reads the new
  /// position from now on. Throws ParameterError as reset().
  void push_to(double position_m, double velocity_m_per_s = 0.0);

  /// The force disturbance (ForceDisturbanceParameters) back to its time 0,
  /// the rest of the state kept: runs started after it meet the same
  /// disturbance (common random numbers, to compare laws run by run).
  void restart_disturbance() noexcept { disturbance_.reset(); }

  /// The static truth K^l(y) [N/A, N/A, N·m/A] and F_cog(y) [N, N, N·m], and
  /// the direction-dependent term at a velocity [N, N, N·m].
  CoilGain true_gain(int coil_set, double position_m) const noexcept { return truth_.gain(coil_set, position_m); }
  Wrench true_cogging(double position_m) const noexcept { return truth_.cogging(position_m); }
  Wrench direction_dependent(double velocity_m_per_s) const noexcept {
    return truth_.direction_dependent(velocity_m_per_s);
  }
  const ElectromagneticTruth& electromagnetics() const noexcept { return truth_; }
  /// The wrench `setpoints` (magnitude/phase drive) or `currents` (phase-current
  /// drive; the one of the drive's profile is used, the other may be empty)
  /// make at `position_m` through an ideal drive: the drive's own
  /// commutation and current limit, its currents equal to their references,
  /// no delay, whether enabled or not; without the direction-dependent force
  /// [N, N, N·m]. The static map a commutation law inverts
  /// (docs/simulator.md, "Oracle commutation"). One entry per coil set.
  Wrench ideal_drive_wrench(double position_m, std::span<const DriveSetpoint> setpoints,
                            std::span<const PhaseCurrentSetpoint> currents) const noexcept;
  const MotorParameters& parameters() const noexcept { return parameters_; }
  int coil_sets() const noexcept { return truth_.coil_sets(); }

  /// Number of substeps step(period_s) uses, −1 if it would exceed 10^7.
  int substeps(double period_s) const noexcept;

 private:
  /// The checks both command kinds share: the drive's profile, one setpoint
  /// per coil set, finite values. A refusal latches kStatusInvalidSetpoint.
  CommandResult check_command(DriveProfile profile, std::size_t count, bool finite) noexcept;
  /// Takes an accepted command: enable, the watchdog's time, the outputs.
  void take_command(bool enable) noexcept;
  bool drive_active() const noexcept;
  void latch_fault(std::uint32_t bits) noexcept;
  /// Throws ParameterError naming `what` for a position outside the end stops or a velocity not finite.
  void require_between_stops(const char* what, double position_m, double velocity_m_per_s) const;
  /// Phase current setpoints of the drive with the translator at
  /// `position_m`, after its current limit (zero when not active); true if
  /// limited. The drive commutates on its encoder's reading, the position
  /// plus the power-up offset.
  bool drive_currents(double position_m, CurrentVector& currents_A) const noexcept;
  /// The position latch: an event between the read head's positions
  /// `from_m` and `to_m` (one substep) latches it when armed.
  void watch_latch(double from_m, double to_m) noexcept;
  /// The encoder's reading at the read head's true position `position_m`,
  /// without interpolation error and noise, quantised.
  double counter_reading_m(double position_m) const noexcept;
  /// The same for given setpoints (the profile's), whether active or not.
  bool phase_currents(double position_m, std::span<const DriveSetpoint> setpoints,
                      std::span<const PhaseCurrentSetpoint> currents, CurrentVector& currents_A) const noexcept;
  /// The windings' currents after a substep of `h_s` towards `reference_A`
  /// (the current loop, or the reference itself when ideal) into currents_A_.
  void drive_windings(const CurrentVector& reference_A, double h_s) noexcept;
  /// Setpoints received: in effect now, or after DriveParameters::setpoint_delay_s.
  void take_setpoints(std::span<const DriveSetpoint> setpoints, std::span<const PhaseCurrentSetpoint> currents) noexcept;
  /// The oldest pending setpoints into effect.
  void take_pending() noexcept;
  /// Takes the pending setpoints whose time has come by `time_s`.
  void apply_due_setpoints(double time_s) noexcept;
  /// The read head's position `delay_s` before now, from the history.
  double encoder_side_position_m(double delay_s) const noexcept;
  double motor_side_mass_kg() const noexcept;
  double friction_N(double velocity_m_per_s) const noexcept;
  /// The same with friction_tanh = tanh(v/v_s) given.
  double friction_N(double velocity_m_per_s, double friction_tanh) const noexcept;
  /// Updates currents_, wrench_ for the present state.
  void update_outputs() noexcept;
  /// The truth's position terms at `position_m`, computed again only when the
  /// position's bits changed: a period evaluates the force at the position it
  /// ended on three times (end of step, command, first substep).
  const ElectromagneticTruth::PositionTerms& position_terms(double position_m) noexcept;

  MotorParameters parameters_;
  ElectromagneticTruth truth_;
  RandomStream noise_;

  // Mechanical state.
  double time_s_ = 0.0;
  double position_m_ = 0.0;
  double velocity_m_per_s_ = 0.0;
  double disturbance_force_N_ = 0.0;
  double payload_kg_ = 0.0;
  bool in_contact_ = false;

  // The read head's side of the flexible mode (the motor side's when rigid).
  double encoder_position_m_ = 0.0;
  double encoder_velocity_m_per_s_ = 0.0;
  // The read head's positions at the ends of the latest substeps, for the
  // encoder's delay: a ring of kEncoderHistory.
  static constexpr int kEncoderHistory = 512;
  std::array<double, kEncoderHistory> history_time_s_{};
  std::array<double, kEncoderHistory> history_position_m_{};
  int history_next_ = 0;
  int history_count_ = 0;
  // The incremental encoder's power-up offset (drawn once, SensorParameters).
  double encoder_offset_m_ = 0.0;
  // The position latch (set_latch): armed, caught, not yet taken.
  bool latch_armed_ = false, latch_caught_ = false, latch_fresh_ = false;
  LatchSource latch_source_ = LatchSource::kIndex;
  double latch_position_m_ = 0.0;
  // The interpolation error's phases (drawn once from the noise seed).
  double interpolation_phase_rad_[2] = {0.0, 0.0};
  ForceDisturbance disturbance_;
  CurrentLoop current_loop_;
  CurrentVector reference_A_;  ///< the drive's current setpoints in the last substep

  // Setpoints received but not yet applied (DriveParameters::setpoint_delay_s).
  struct Pending {
    double due_s = 0.0;
    std::array<DriveSetpoint, kMaxCoilSets> setpoints{};
    std::array<PhaseCurrentSetpoint, kMaxCoilSets> currents{};
  };
  static constexpr int kPendingCapacity = 32;
  std::array<Pending, kPendingCapacity> pending_{};
  int pending_first_ = 0;
  int pending_count_ = 0;

  // Drive state.
  std::array<DriveSetpoint, kMaxCoilSets> setpoints_{};
  std::array<PhaseCurrentSetpoint, kMaxCoilSets> commanded_currents_{};
  bool enable_requested_ = false;
  double enabled_at_s_ = 0.0;  // when enable_requested_ last became true
  double last_command_time_s_ = 0.0;
  std::uint32_t latched_ = 0;
  bool limited_in_last_step_ = false;

  // Outputs of the present state.
  CurrentVector currents_A_;
  Wrench wrench_ = Wrench::Zero();
  // The last step()'s means over its substeps (TruthState::step_wrench).
  CurrentVector step_mean_currents_A_;
  double step_mean_position_m_ = 0.0;

  // The last position_terms(); valid once computed (the truth is fixed).
  ElectromagneticTruth::PositionTerms terms_;
  bool terms_valid_ = false;

  int end_stop_collisions_ = 0;
  double last_impact_speed_m_per_s_ = 0.0;
  long current_limited_substeps_ = 0;
};

}  // namespace clm::sim
