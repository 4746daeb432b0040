#pragma once
// The servo cycle: everything one period of clm-servod does between its wake-up
// and its last frame, without I/O of its own. The loop around it (real-time
// or virtual clock, SocketCAN or the in-process simulated motor) hands it the
// commands and the received frames and sends the frames it returns (see
// ServoCycle). The cycle does not allocate, lock, throw or log; faults latch
// with a reason (fault.hpp). Objects built elsewhere (move programs,
// commutation laws) come in through its mailbox (cycle_mailbox.hpp) and are
// adopted between cycles.

#include <array>
#include <cstdint>
#include <span>

#include "commutation/commutator.hpp"
#include "commutation/current_loop_compensation.hpp"
#include "daemon/control/envelope.hpp"
#include "daemon/control/homing.hpp"
#include "daemon/control/position_controller.hpp"
#include "daemon/control/stop_profile.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/servo/command.hpp"
#include "daemon/servo/command_result.hpp"
#include "daemon/servo/cycle_mailbox.hpp"
#include "daemon/servo/cycle_record.hpp"
#include "daemon/servo/fault.hpp"
#include "daemon/servo/tuning.hpp"
#include "drivers/can_bus.hpp"
#include "drivers/can/can_protocol.hpp"

namespace clm::servo {

struct ServoSettings {
  double period_s = 1e-3;
  double pole_pitch_m = 0.0;
  DriveCommutation drive;
  /// The drive's current loop (drive.current_loop of the motor file): the
  /// cycle sends the references that make it deliver the law's currents.
  CurrentLoopModel current_loop;
  /// The drive's delay from setpoint to force (drive.setpoint_delay_s of the motor file) [s].
  double setpoint_delay_s = 0.0;
  /// How long after a cycle its force demand reaches the translator, the
  /// delay plus the current loop's lag τ_s + 1/ω_c: the feedforward is
  /// taken from the reference this far ahead (docs/servod.md, "The
  /// feedforward's lead") [s].
  double force_lag_s() const noexcept { return setpoint_delay_s + current_loop.lag_s(); }
  /// The sign convention of the setpoints the cycle derives itself (commutation.phase_convention).
  PhaseConvention phase_convention = PhaseConvention::kSignedMagnitude;
  can::ProtocolConfig protocol;
  control::PidGains pid{};
  control::FeedforwardParameters feedforward{};
  double soft_limit_min_m = -0.1;
  double soft_limit_max_m = 0.1;
  double following_error_limit_m = 1e-3;
  double force_limit_N = 500.0;           ///< |F*| is limited to this (reported, never silent)
  double saturation_time_limit_s = 0.05;  ///< fault when limited longer than this
  int missing_frame_limit = 3;            ///< consecutive cycles without a timely, valid feedback frame → fault
  int overrun_limit = 5;                  ///< consecutive overruns → fault
  /// A loop that did not wake for longer than this latches kLoopStalled when
  /// it resumes (a stall, SIGSTOP), whatever the drive did meanwhile [s].
  double stall_limit_s = 0.1;
  /// Enable completes when the drive reports Enabled; not within this time
  /// after the enable, kDriveNotEnabled [s].
  double enable_timeout_s = 0.1;
  /// The drive limiting its current for longer than this latches
  /// kDriveCurrentLimited [s].
  double current_limited_limit_s = 0.1;
  double standstill_velocity_m_per_s = 2e-3;
  /// Largest velocity, acceleration and jerk a move or program may ask for.
  control::MotionLimits motion_limits{0.5, 10.0, 2000.0};
  /// Limits of a stop (stop command) and of a quick stop (quick-stop command,
  /// approach guard, fault reactions); quick-stop values ≥ the stop's.
  control::StopLimits stop_limits{10.0, 2000.0};
  control::StopLimits quick_stop_limits{10.0, 2000.0};
  /// Restricted mode after kPositionOutOfRange: moves back inside at most at
  /// this share of motion_limits.velocity_m_per_s, enabled only within this
  /// distance beyond a soft limit [m].
  double recovery_velocity_fraction = 0.1;
  double recovery_margin_m = 0.02;
  /// A jog stops (stop_limits) when no repeat renewed it for this long [s].
  double jog_timeout_s = 0.25;
  /// The machine the safe envelope is derived from (control::check_envelope).
  control::Machine machine{};
  /// How the axis finds its commutation and its reference (docs/servod.md, "Homing").
  control::HomingSettings homing{};
  /// Throws std::invalid_argument naming the setting, or the relation of the
  /// safe envelope the settings together break.
  void validate() const;
  /// The settings that may change at run time, and these settings with `tuning`'s.
  Tuning tuning() const noexcept;
  void apply(const Tuning& tuning) noexcept;
};

struct CycleCounters {
  std::int64_t cycles = 0;
  std::int64_t frames_sent = 0;
  std::int64_t frames_received = 0;
  std::int64_t frames_missing = 0;   ///< expected feedback frames that did not come in time
  std::int64_t frames_late = 0;      ///< feedback frames stamped before their cycle's SYNC
  std::int64_t frames_rejected = 0;  ///< wrong length/content, or an unexpected ID
  std::int64_t frames_duplicate = 0;
  std::int64_t overruns = 0;
  std::int64_t damping_cycles = 0;
  std::int64_t force_limited_cycles = 0;
  std::int64_t programs_rejected = 0;  ///< offers the cycle did not start (each answered: last_offer_result)
  std::int64_t stops = 0;           ///< stops planned (stop command)
  std::int64_t quick_stops = 0;     ///< quick stops planned (command, approach guard, fault reaction)
  std::int64_t guard_stops = 0;     ///< of those, by the approach guard
  std::int64_t jog_timeouts = 0;    ///< jogs stopped because no renewal came within jog_timeout_s
  std::int64_t force_sensor_losses = 0;  ///< times the force sensor was lost in service (a warning, not a fault)
  std::int64_t current_limited_cycles = 0;  ///< enabled cycles whose feedback said the drive limited its current
};

/// What the cycle reports of itself; read on the loop thread (an observer,
/// the daemon between cycles).
struct CycleStatus {
  ServoState state = ServoState::kDisabled;
  Fault fault = Fault::kNone;
  std::int64_t fault_cycle = -1;  ///< the cycle the fault latched in (-1: none)
  CommutationMode mode = CommutationMode::kOriginal;
  bool mode_change_pending = false;  ///< a requested law waits for standstill (kDeferred)
  bool stopping = false;             ///< a stop (command, guard or fault reaction) is under way
  bool fault_reaction_running = false;  ///< still driven along a quick stop after a fault latched
  /// Enabled, and the drive has not reported Enabled yet: setpoints zero
  /// with the enable bit, the hold where the axis was, a program's clock
  /// held at its start (docs/servod.md, "The drive's own signals").
  bool enabling = false;
  /// What the drive said of itself in its last feedback.
  drivers::DriveSignals drive;
  /// The drive's commutation is known: found since start-up, or the axis
  /// has an absolute encoder (homing.method none).
  bool commutation_found = false;
  /// Positions are in the axis frame the files were made in: homed since
  /// start-up, or an absolute encoder. Until then they are the encoder's
  /// reading, moves to positions and position-dependent laws are refused.
  bool homed = false;
  HomingPhase homing = HomingPhase::kIdle;
  /// The last commutation finding's phase (the Δ of most force on the
  /// drive's raw commutation) [rad], and the last homing's offset, axis
  /// position less the encoder's reading [m].
  double found_phase_rad = 0.0;
  double axis_offset_m = 0.0;
  /// The force sensor's warning: kNone while it is healthy (or the axis has
  /// none), else why it was lost in service (kForceFrameMissing,
  /// kForceAliveJump, kFrameRejected, kMeasurementNotFinite). In an
  /// experiment the same latches as a fault. Clears after missing_frame_limit
  /// good cycles.
  Fault force_sensor_warning = Fault::kNone;
  /// The decision on the last offer (CycleMailbox): kProgramPosted,
  /// kJogStarted, or why it did not start (kRejectedFault, kRejectedDisabled,
  /// kRejectedBusy, kRejectedRestricted, kRejectedStartMoved).
  CommandResult last_offer_result = CommandResult::kAccepted;
  CycleCounters counters;
};

/// What the loop tells the cycle as it starts one.
struct CycleStart {
  std::int64_t sync_time_ns = 0;  ///< when its SYNC leaves (CLOCK_MONOTONIC or virtual)
  /// Time since the previous cycle's wake-up [s]; above stall_limit_s it
  /// latches kLoopStalled (0 on the virtual clock).
  double wakeup_gap_s = 0.0;
  /// The previous cycle overran its period; overrun_limit in a row latch kRepeatedOverruns.
  bool previous_overran = false;
};

/// The bus as the loop found it: before the setpoints are built (end_cycle)
/// and after they were sent (sent).
struct BusReport {
  drivers::BusState state = drivers::BusState::kActive;
  bool send_failed = false;
};

/// One axis's cycle. Its interface, in the order the loop uses it:
///
///   execute(command)                   between cycles, the commands (command.hpp)
///   SYNC = begin_cycle(start)          → send
///   on_frame(f)                        ← every frame until feedback_complete() or the deadline
///   frames = end_cycle(time, bus)      → send the setpoints
///   sent(bus)
///
/// and status() / record() after it. A cycle is split where the bus makes the
/// loop wait (SYNC out, feedback in), not into one update(): the feedback of
/// a cycle exists only after its SYNC has left. Offers from other threads go
/// through mailbox().
class ServoCycle {
 public:
  /// Validates the settings (throws std::invalid_argument).
  explicit ServoCycle(const ServoSettings& settings);

  /// Set-up, before the loop starts: the law for a mode (nullptr: none).
  void install_law(CommutationMode mode, const CommutationLaw* law) noexcept;
  /// Set-up, after install_law: the law the configuration names, at once;
  /// on an axis that must home first and a law that is a function of
  /// position, the drive's own law until homing completes, then this one.
  CommandResult start_with(CommutationMode mode) noexcept;
  /// Any thread: what the owner offers the cycle and reads back (cycle_mailbox.hpp).
  CycleMailbox& mailbox() noexcept { return mailbox_; }
  const CycleMailbox& mailbox() const noexcept { return mailbox_; }

  /// Loop thread, between cycles: a command the cycle answers
  /// (servo::answered_by_cycle, except the moves, which come as offers
  /// through the mailbox):
  ///  - enable closes the loop at the present position; with
  ///    kPositionOutOfRange latched and the axis outside the soft limits but
  ///    within recovery_margin_m of them, it clears it and enables in
  ///    restricted mode;
  ///  - stop brakes a running program within stop_limits and holds; quick
  ///    stop does so within quick_stop_limits and also shortens a stop under way;
  ///  - set_commutation / set_experiment switch the law at the next
  ///    standstill (kDeferred); any law but the experiment becomes the service
  ///    law, which disable and every fault return to;
  ///  - load_feedforward takes effect at once; set_parameter (a validated
  ///    Tuning) only when no program or stop runs (kRejectedBusy otherwise).
  CommandResult execute(const Command& command) noexcept;
  /// Loop thread: the holder of a deadman lease is gone: ends an experiment
  /// at once (the service law drives from this cycle on) and quick-stops a
  /// running program.
  void owner_gone() noexcept;

  /// Starts a cycle: adopts the offers, returns the SYNC frame.
  can::Frame begin_cycle(const CycleStart& start) noexcept;
  /// A frame received during the cycle.
  void on_frame(const drivers::ReceivedFrame& frame) noexcept;
  /// The feedback frames of this cycle are in: the drive's, and the force
  /// sensor's when the axis has one (also while it is lost: its frame, when it
  /// comes again, must not be left for the next cycle as a late one).
  bool feedback_complete() const noexcept {
    return drive_fresh_ && (force_fresh_ || !can::has_force_sensor(settings_.protocol));
  }
  /// Checks, position loop, commutation, setpoint frames. `time_s` is the
  /// cycle's time for the record; a bus fault in `bus` zeroes this cycle's setpoints.
  std::span<const can::Frame> end_cycle(double time_s, const BusReport& bus) noexcept;
  /// The bus after the setpoints were sent.
  void sent(const BusReport& bus) noexcept;

  const CycleStatus& status() const noexcept { return status_; }
  const CycleRecord& record() const noexcept { return record_; }
  const ServoSettings& settings() const noexcept { return settings_; }
  /// The law the cycle uses for `mode` now (nullptr: none).
  const CommutationLaw* law(CommutationMode mode) const noexcept { return laws_[static_cast<std::size_t>(mode)]; }

 private:
  // The commands (execute).
  CommandResult enable() noexcept;
  CommandResult disable() noexcept;
  CommandResult clear_fault() noexcept;
  CommandResult stop() noexcept;
  CommandResult quick_stop() noexcept;
  /// Enables if needed (with commutation finding), then searches the reference.
  CommandResult home() noexcept;
  /// For kExperiment, `coil_set` (1-based) and `delta_rad` select the experiment.
  CommandResult request_mode(CommutationMode mode, int coil_set = 0, double delta_rad = 0.0) noexcept;
  void set_feedforward(const control::FeedforwardParameters& parameters) noexcept;
  CommandResult apply_tuning(const Tuning& tuning) noexcept;
  /// Bus faults latch; a failed send too.
  void report_bus(const BusReport& bus) noexcept;
  bool at_standstill() const noexcept;

  void latch(Fault fault) noexcept;
  /// Whether `counter` follows the stream's last one (frames owed: `unseen`).
  bool track_alive(std::uint8_t counter, std::uint8_t& last, bool& known, int& unseen, bool late) noexcept;
  /// Missing frames, the position and velocity estimate, the drive's signals.
  void account_feedback() noexcept;
  /// The reactions to the drive's signals: its faults, the enable
  /// handshake, the current limit's duration.
  void react_to_drive(const drivers::DriveSignals& signals) noexcept;
  /// Enabling: the drive not yet applying current; the record as follow_axis, the hold kept.
  void wait_for_drive() noexcept;
  void account_force_feedback() noexcept;
  /// A fault in an experiment, else the force sensor's warning.
  void force_sensor_trouble(Fault reason) noexcept;
  // Homing (servo_cycle_homing.cpp).
  /// The loop has just closed (the handshake done): commutation finding
  /// first where the commutation is unknown, then a requested search.
  void after_enable() noexcept;
  /// One period of commutation finding: the open-loop doublet's setpoints.
  void find_commutation() noexcept;
  void begin_search() noexcept;
  /// The search's reference from rest at `position_m` towards `direction` (±1).
  void search_from(double position_m, int direction) noexcept;
  /// The reference found at the encoder's `reading_m`: stop from `now`, then move the frame.
  void stop_at_reference(const control::ReferenceSample& now, double reading_m) noexcept;
  /// Stops the search from its reference `now` (HomingPhase::kStopping).
  void stop_search(const control::ReferenceSample& now) noexcept;
  /// The search at its reference `now`: its method's watch, then the distance (fault 217).
  void watch_search(const control::ReferenceSample& now) noexcept;
  /// A latch received stops it (or, index_in_switch, the switch's edge arms
  /// the index); a latch without its frame latches 218. True when it decided.
  bool watch_latch(const control::ReferenceSample& now) noexcept;
  /// The following error says the axis stands at the stop: back off, then
  /// stop. True when it decided.
  bool watch_hard_stop(const control::ReferenceSample& now) noexcept;
  /// At rest after the latch: the position frame moves to the reference.
  void finish_homing() noexcept;
  /// Ends homing where it is: a stop, a disable, a fault.
  void abort_homing() noexcept;
  /// Homing moves the axis along search_: searching, leaving the switch, backing off.
  bool homing_moves() const noexcept {
    return status_.homing == HomingPhase::kSearching || status_.homing == HomingPhase::kBackingOff ||
           status_.homing == HomingPhase::kLeavingSwitch;
  }
  /// Homing to the hard stop: searching or backing off, the force limited.
  bool pushing_to_hard_stop() const noexcept {
    return settings_.homing.method == control::HomingMethod::kHardStop && homing_moves();
  }
  /// The law a mode needs homing for (every one but the drive's own).
  bool needs_homing(CommutationMode mode) const noexcept;
  /// Setpoints for the drive's commutation on its raw reading: Δ shifted by
  /// the axis frame's offset (profile magnitude_phase).
  void shift_to_drive_frame() noexcept;
  void adopt_offers() noexcept;
  // The steps of end_cycle, in order.
  /// Fault 202 outside the soft limits; restricted mode ends inside them.
  void check_soft_limits() noexcept;
  /// Enabled or reacting to a fault: the reference (program, jog, stop or
  /// hold), the approach guard, the position loop and the commutation.
  void drive() noexcept;
  void approach_guard(const control::ReferenceSample& now, const control::ReferenceSample& next) noexcept;
  /// Not driven: the reference follows the axis so that enabling is bumpless.
  void follow_axis() noexcept;
  /// The reference at rest at `position_m`, no force asked: the record and the reference.
  void rest_at(double position_m) noexcept;
  /// The setpoint frames with the enable bit `enable` (zero at once on a
  /// fault found while encoding); their count.
  std::size_t encode_setpoints(bool enable) noexcept;
  void fill_record(double time_s) noexcept;
  void commutate(double position_m, double velocity_m_per_s, double force_N) noexcept;
  void zero_setpoints() noexcept;
  /// Plans a stop from the present reference and follows it from the next sample.
  void begin_stop(const control::StopLimits& limits, bool quick) noexcept;
  void end_program() noexcept;
  /// An experiment is in use or waits for standstill.
  bool in_experiment() const noexcept {
    return status_.mode == CommutationMode::kExperiment ||
           (status_.mode_change_pending && requested_mode_ == CommutationMode::kExperiment);
  }
  /// Back to the service law at once, a pending experiment dropped (disable, fault, owner gone).
  void leave_experiment() noexcept;
  bool outside_soft_limits(double position_m) const noexcept;

  ServoSettings settings_;
  control::PositionController controller_;
  std::array<const CommutationLaw*, kCommutationModes> laws_{};
  CycleMailbox mailbox_;
  const control::MoveProgram* running_ = nullptr;
  std::int64_t program_start_cycle_ = 0;
  // Velocity observer (account_feedback): the reference's acceleration
  // predicts, the position difference corrects through a first-order filter
  // with this time constant [s], enough to tell standstill from motion
  // through encoder noise.
  static constexpr double kVelocityFilter_s = 0.01;
  std::int64_t jog_token_seen_ = 0, jog_renewed_cycle_ = 0;

  CycleStatus status_;
  bool clear_drive_fault_ = false;
  CommutationMode requested_mode_ = CommutationMode::kOriginal;
  CommutationMode service_mode_ = CommutationMode::kOriginal;  // the last law requested other than kExperiment
  int experiment_coil_set_ = 0, requested_coil_set_ = 0;
  double experiment_delta_rad_ = 0.0, requested_delta_rad_ = 0.0;

  // Feedback of the current cycle.
  std::int64_t cycle_ = 0;
  std::int64_t sync_time_ns_ = 0;
  bool previous_period_lost_ = false;  // CycleStart: an overrun, or a wake-up a period late
  std::uint8_t sync_counter_ = can::kSyncCounterFirst;
  bool drive_fresh_ = false, force_fresh_ = false;
  can::DriveFeedback drive_{};
  can::ForceFeedback force_{};
  std::uint8_t drive_alive_ = 0, force_alive_ = 0;
  bool drive_alive_known_ = false, force_alive_known_ = false;
  int drive_missed_ = 0, force_missed_ = 0;  // consecutive cycles without a timely, valid frame
  int drive_unseen_ = 0, force_unseen_ = 0;  // frames owed since the last one received (alive-counter gap)
  bool drive_rejected_ = false, force_rejected_ = false;  // a frame was rejected since the last timely one
  int force_good_ = 0;                    // good force cycles in a row while warned
  bool have_position_ = false;
  double position_m_ = 0.0, previous_position_m_ = 0.0;
  double velocity_estimate_m_per_s_ = 0.0;
  // Homing: the axis frame (position = reading + axis_offset_m), the
  // commutation frame (the laws' position = reading + commutation offset).
  double commutation_offset_m_ = 0.0;
  control::CommutationFinder finder_;
  control::SearchProfile search_;
  std::int64_t search_start_cycle_ = 0;
  bool home_requested_ = false;
  bool latch_received_ = false, latch_checked_ = false, latch_in_span_ = false, homing_complete_ = false;
  bool awaiting_index_ = false;  // index_in_switch: the switch's edge latched, the index next
  bool search_again_ = false;    // out of the reference switch: at rest, the search starts again
  CommutationMode mode_after_homing_ = CommutationMode::kOriginal;  // start_with's law, once homed
  double contact_m_ = 0.0, contact_reading_m_ = 0.0;  // hard_stop: where it met the stop (axis frame, reading)
  double latched_reading_m_ = 0.0, pending_offset_m_ = 0.0;
  int latch_frame_wait_ = 0;

  // Reference and loop.
  control::ReferenceSample reference_{};  // the reference of cycle reference_cycle_
  std::int64_t reference_cycle_ = 0;
  control::StopProfile stop_profile_;
  std::int64_t stop_start_cycle_ = 0;
  bool stop_quick_ = false;
  double restricted_min_m_ = 0.0, restricted_max_m_ = 0.0;
  double hold_m_ = 0.0;
  double saturated_time_s_ = 0.0;
  std::int64_t enable_wait_periods_ = 0;      // since enable, while enabling
  std::int64_t current_limited_periods_ = 0;  // the drive's current limit active without a break
  int consecutive_overruns_ = 0;

  // Output.
  std::uint8_t setpoint_alive_ = 0;
  CommutationOutput commutation_;
  CurrentLoopCompensation compensation_;
  CurrentVector references_A_;  // the currents asked of the drive's current loop
  can::SetpointCommand commanded_;  // this cycle's, from the law or the experiment; the record copies them
  can::SetpointCommand setpoints_;  // as sent: commanded_, corrected for the drive's current loop
  std::array<can::Frame, can::kMaxSetpointFrames> frames_{};
  CycleRecord record_;
};

}  // namespace clm::servo
