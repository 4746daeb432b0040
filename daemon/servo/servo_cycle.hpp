#pragma once
// The servo cycle: everything one period of clm-servod does between its wake-up
// and its last frame, without I/O of its own. The loop around it (real-time
// or virtual clock, SocketCAN or the in-process simulated motor) hands it the
// received frames and sends the frames it returns:
//
//   SYNC = begin_cycle(t)   → send
//   on_frame(f)              ← every frame received until the deadline
//   frames = end_cycle()     → send the setpoints
//
// The cycle does not allocate, lock, throw or log; faults latch with a reason
// (fault.hpp). Objects built elsewhere (move programs, commutation laws) come
// in through Handover slots and are adopted between cycles.

#include <array>
#include <cstdint>
#include <span>

#include "commutation/commutator.hpp"
#include "daemon/control/envelope.hpp"
#include "daemon/control/position_controller.hpp"
#include "daemon/control/stop_profile.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/servo/command_result.hpp"
#include "daemon/servo/cycle_record.hpp"
#include "daemon/servo/fault.hpp"
#include "daemon/servo/handover.hpp"
#include "daemon/servo/tuning.hpp"
#include "drivers/can_bus.hpp"
#include "drivers/can/can_protocol.hpp"

namespace clm::servo {

struct ServoSettings {
  double period_s = 1e-3;
  double pole_pitch_m = 0.0;
  DriveCommutation drive;
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
};

class ServoCycle {
 public:
  /// Validates the settings (throws std::invalid_argument).
  explicit ServoCycle(const ServoSettings& settings);

  // --- set-up and owner side (not the real-time thread) ---
  /// Law for a mode before the loop starts (nullptr: not available).
  void install_law(CommutationMode mode, const CommutationLaw* law) noexcept;
  /// Offer a new law for a mode; the cycle adopts it at the next standstill.
  Handover<CommutationLaw>& law_handover(CommutationMode mode) noexcept;
  /// Offer a move program; the cycle starts it at the next cycle if it is
  /// enabled, idle and at the program's start (within 1 µm), else drops it and
  /// counts it in programs_rejected. Either way offers_decided() counts it and
  /// last_offer_result() says which, for the daemon to answer the command.
  Handover<control::MoveProgram>& program_handover() noexcept { return program_; }
  /// Offer a jog: a move program the cycle runs like any other (program_handover)
  /// but stops along stop_limits when renew_jog() has not been called for
  /// settings().jog_timeout_s. False if an earlier offer is still pending.
  bool post_jog(const control::MoveProgram* jog) noexcept;
  /// Keeps the running jog going; false when no jog runs or the cycle has
  /// already begun its stop (then the jog is over: post a new one).
  bool renew_jog() noexcept;
  /// A jog runs and has not been stopped.
  bool jogging() const noexcept { return jogging_.load(std::memory_order_acquire); }
  /// A jog was offered (post_jog) and the cycle has not taken it yet; it starts
  /// with a fresh jog_timeout_s when it does.
  bool jog_pending() const noexcept {
    return jog_offer_.load(std::memory_order_acquire) != nullptr && program_.pending();
  }
  /// Position the axis holds when idle [m] (for planning a move from it).
  double hold_position_m() const noexcept { return hold_position_m_.load(std::memory_order_acquire); }
  bool idle() const noexcept { return idle_.load(std::memory_order_acquire); }
  /// Restricted mode (enabled outside the soft limits after
  /// kPositionOutOfRange): only a move back inside at reduced speed starts.
  bool restricted() const noexcept { return restricted_.load(std::memory_order_acquire); }

  // --- commands, called on the real-time thread between cycles ---
  /// Closes the loop at the present position. With kPositionOutOfRange
  /// latched and the axis outside the soft limits but within
  /// recovery_margin_m of them, clears it and enables in restricted mode.
  CommandResult enable() noexcept;
  CommandResult disable() noexcept;
  CommandResult clear_fault() noexcept;
  /// Stop a running program: the reference brakes from its present state
  /// within settings().stop_limits (control::StopProfile) and then holds.
  CommandResult stop() noexcept;
  /// As stop(), within settings().quick_stop_limits; also shortens a stop
  /// under way.
  CommandResult quick_stop() noexcept;
  /// Switch the commutation law (deferred to standstill). For kExperiment,
  /// `coil_set` (1-based) and `delta_rad` select the experiment. Any other
  /// law becomes the service law, which disable() and every fault return to
  /// (an experiment never survives either).
  CommandResult request_mode(CommutationMode mode, int coil_set = 0, double delta_rad = 0.0) noexcept;
  /// Ends an experiment in use or pending: back to the service law at the
  /// next standstill (at once when the axis is not driven), as request_mode.
  /// kAccepted when there is none.
  CommandResult end_experiment() noexcept;
  /// Replace the feedforward parameters (takes effect at once).
  void set_feedforward(const control::FeedforwardParameters& parameters) noexcept;
  /// Replace the run-time settings (gains, feedforward, limits) when no
  /// program or stop runs (kRejectedBusy otherwise). The caller has
  /// validated them (ServoSettings::validate on settings().apply(tuning)).
  CommandResult apply_tuning(const Tuning& tuning) noexcept;

  // --- the cycle ---
  /// Starts a cycle whose SYNC leaves at `sync_time_ns` (CLOCK_MONOTONIC or
  /// virtual): adopts offered objects, returns the SYNC frame.
  can::Frame begin_cycle(std::int64_t sync_time_ns) noexcept;
  /// A frame received during the cycle.
  void on_frame(const drivers::ReceivedFrame& frame) noexcept;
  /// The feedback frames of this cycle are in: the drive's, and the force
  /// sensor's when the axis has one (also while it is lost: its frame, when it
  /// comes again, must not be left for the next cycle as a late one).
  bool feedback_complete() const noexcept {
    return drive_fresh_ && (force_fresh_ || !can::has_force_sensor(settings_.protocol));
  }
  /// Checks, position loop, commutation, setpoint frames. `time_s` is the
  /// cycle's time for the record.
  std::span<const can::Frame> end_cycle(double time_s) noexcept;
  /// The loop reports whether the previous cycle overran its period.
  void report_overrun(bool overran) noexcept;
  /// The loop reports, before a cycle, the time since the previous cycle's
  /// wake-up [s]: above settings().stall_limit_s it latches kLoopStalled.
  void report_wakeup_gap(double gap_s) noexcept;
  /// The loop reports the bus state and whether sending failed.
  void report_bus(drivers::BusState state, bool send_failed) noexcept;

  // --- state ---
  /// Offers (program_handover, post_jog) the cycle has taken or dropped so
  /// far, and its decision on the last one: kProgramPosted, kJogStarted, or
  /// why it did not start it (kRejectedFault, kRejectedDisabled,
  /// kRejectedBusy, kRejectedRestricted, kRejectedStartMoved).
  /// offers_decided: any thread; last_offer_result: the loop thread.
  std::int64_t offers_decided() const noexcept { return offers_decided_.load(std::memory_order_acquire); }
  CommandResult last_offer_result() const noexcept { return last_offer_result_; }
  ServoState state() const noexcept { return state_; }
  Fault fault() const noexcept { return fault_; }
  std::int64_t fault_cycle() const noexcept { return fault_cycle_; }
  CommutationMode mode() const noexcept { return mode_; }
  /// A requested law waits for standstill (request_mode said kDeferred).
  bool mode_change_pending() const noexcept { return mode_pending_; }
  /// The law the cycle uses for `mode` now (nullptr: none).
  const CommutationLaw* law(CommutationMode mode) const noexcept { return laws_[static_cast<std::size_t>(mode)]; }
  const CycleRecord& record() const noexcept { return record_; }
  const CycleCounters& counters() const noexcept { return counters_; }
  const ServoSettings& settings() const noexcept { return settings_; }
  bool at_standstill() const noexcept;
  /// A stop (command, guard or fault reaction) is under way.
  bool stopping() const noexcept { return stopping_; }
  /// The axis is still driven along a quick stop after a fault latched.
  bool fault_reaction_running() const noexcept { return reacting_; }
  /// The force sensor's warning: kNone while it is healthy (or the axis has
  /// none), else why it was lost in service (kForceFrameMissing,
  /// kForceAliveJump, kFrameRejected, kMeasurementNotFinite). In an experiment
  /// the same latches as a fault. Clears after missing_frame_limit good cycles.
  Fault force_sensor_warning() const noexcept { return force_warning_; }

 private:
  void latch(Fault fault) noexcept;
  /// Whether `counter` follows the stream's last one (frames owed: `unseen`).
  bool track_alive(std::uint8_t counter, std::uint8_t& last, bool& known, int& unseen, bool late) noexcept;
  /// Missing frames, the position and velocity estimate, the drive's fault bit.
  void account_feedback() noexcept;
  void account_force_feedback() noexcept;
  /// A fault in an experiment, else the force sensor's warning.
  void force_sensor_trouble(Fault reason) noexcept;
  void adopt_offers() noexcept;
  void commutate(double position_m, double force_N) noexcept;
  void zero_setpoints() noexcept;
  /// Plans a stop from the present reference and follows it from the next sample.
  void begin_stop(const control::StopLimits& limits, bool quick) noexcept;
  void end_program() noexcept;
  /// An experiment is in use or waits for standstill.
  bool in_experiment() const noexcept {
    return mode_ == CommutationMode::kExperiment || (mode_pending_ && requested_mode_ == CommutationMode::kExperiment);
  }
  /// Back to the service law at once, a pending experiment dropped (disable, fault).
  void leave_experiment() noexcept;
  bool outside_soft_limits(double position_m) const noexcept;

  ServoSettings settings_;
  control::PositionController controller_;
  std::array<const CommutationLaw*, kCommutationModes> laws_{};
  std::array<Handover<CommutationLaw>, kCommutationModes> law_offers_;
  Handover<control::MoveProgram> program_;
  const control::MoveProgram* running_ = nullptr;
  std::int64_t program_start_cycle_ = 0;
  // Jog: renewals counted in jog_token_ (kJogStopped once the cycle stops
  // it), so that a renewal and the cycle's decision to stop never cross.
  static constexpr std::int64_t kJogStopped = -1;
  // Velocity estimate: first-order filter on the position difference with this
  // time constant [s], enough to tell standstill from motion through encoder noise.
  static constexpr double kVelocityFilter_s = 0.01;
  std::atomic<const control::MoveProgram*> jog_offer_{nullptr};
  std::atomic<std::int64_t> jog_token_{kJogStopped};
  std::atomic<bool> jogging_{false};
  std::int64_t jog_token_seen_ = 0, jog_renewed_cycle_ = 0;
  std::atomic<std::int64_t> offers_decided_{0};
  CommandResult last_offer_result_ = CommandResult::kAccepted;

  ServoState state_ = ServoState::kDisabled;
  Fault fault_ = Fault::kNone;
  std::int64_t fault_cycle_ = -1;
  bool clear_drive_fault_ = false;
  CommutationMode mode_ = CommutationMode::kOriginal;
  CommutationMode requested_mode_ = CommutationMode::kOriginal;
  CommutationMode service_mode_ = CommutationMode::kOriginal;  // the last law requested other than kExperiment
  int experiment_coil_set_ = 0, requested_coil_set_ = 0;
  double experiment_delta_rad_ = 0.0, requested_delta_rad_ = 0.0;
  bool mode_pending_ = false;

  // Feedback of the current cycle.
  std::int64_t cycle_ = 0;
  std::int64_t sync_time_ns_ = 0;
  std::uint8_t sync_counter_ = can::kSyncCounterFirst;
  bool drive_fresh_ = false, force_fresh_ = false;
  can::DriveFeedback drive_{};
  can::ForceFeedback force_{};
  std::uint8_t drive_alive_ = 0, force_alive_ = 0;
  bool drive_alive_known_ = false, force_alive_known_ = false;
  int drive_missed_ = 0, force_missed_ = 0;  // consecutive cycles without a timely, valid frame
  int drive_unseen_ = 0, force_unseen_ = 0;  // frames owed since the last one received (alive-counter gap)
  bool drive_rejected_ = false, force_rejected_ = false;  // a frame was rejected since the last timely one
  Fault force_warning_ = Fault::kNone;  // see force_sensor_warning()
  int force_good_ = 0;                    // good force cycles in a row while warned
  bool have_position_ = false;
  double position_m_ = 0.0, previous_position_m_ = 0.0;
  double velocity_estimate_m_per_s_ = 0.0;

  // Reference and loop.
  control::ReferenceSample reference_{};  // the reference of cycle reference_cycle_
  std::int64_t reference_cycle_ = 0;
  control::StopProfile stop_profile_;
  std::int64_t stop_start_cycle_ = 0;
  bool stopping_ = false, stop_quick_ = false;
  bool reacting_ = false;  // driven along a quick stop while a fault is latched
  std::atomic<bool> restricted_{false};
  double restricted_min_m_ = 0.0, restricted_max_m_ = 0.0;
  double hold_m_ = 0.0;
  std::atomic<double> hold_position_m_{0.0};
  std::atomic<bool> idle_{true};
  double saturated_time_s_ = 0.0;
  int consecutive_overruns_ = 0;

  // Output.
  std::uint8_t setpoint_alive_ = 0;
  CommutationOutput commutation_;
  std::array<can::Frame, can::kMaxSetpointFrames> frames_{};
  CycleRecord record_;
  CycleCounters counters_;
};

}  // namespace clm::servo
