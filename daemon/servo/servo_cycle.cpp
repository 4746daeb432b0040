// The servo cycle itself: begin_cycle adopts what the owner offered and
// sends SYNC; end_cycle runs the reference, the approach guard, the position
// loop and the commutation and encodes the setpoints. Commands and settings
// are in servo_cycle_commands.cpp, the feedback in servo_cycle_feedback.cpp.
#include "daemon/servo/servo_cycle.hpp"

#include <algorithm>
#include <cmath>

#include "daemon/servo/command.hpp"
#include "daemon/servo/move_decision.hpp"

namespace clm::servo {
namespace {

constexpr double kProgramStartTolerance_m = 1e-6;
// A fault reaction stops under position control only while the measured
// position lies within this many following-error limits of the reference;
// farther, the measurement is not believed and the setpoints go to zero.
constexpr double kPlausibleErrorFactor = 10.0;

/// Target of the step of `program` under way at `t_s` (its start before the first).
double step_target_m(const control::MoveProgram& program, double t_s) noexcept {
  const auto& steps = program.steps();
  std::size_t lo = 0, hi = steps.size();  // first step starting after t_s
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (program.step_start_s(mid) <= t_s) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo == 0 ? program.start_m() : steps[lo - 1].target_m;
}

}  // namespace

ServoCycle::ServoCycle(const ServoSettings& settings)
    : settings_((settings.validate(), settings)),
      controller_(settings.pid, settings.feedforward, settings.period_s),
      compensation_(settings.current_loop, settings.period_s) {
  commutation_.currents_A.resize(2 * settings.protocol.coil_sets);
  references_A_.resize(2 * settings.protocol.coil_sets);
  record_.coil_sets = settings.protocol.coil_sets;
  status_.commutation_found = status_.homed = !settings.homing.incremental();
}

void ServoCycle::install_law(CommutationMode mode, const CommutationLaw* law) noexcept {
  const auto index = static_cast<std::size_t>(mode);
  laws_[index] = law;
  mailbox_.laws_[index].set_current(law);
}

bool ServoCycle::at_standstill() const noexcept {
  return running_ == nullptr && !status_.stopping && status_.homing == HomingPhase::kIdle && std::abs(velocity_estimate_m_per_s_) < settings_.standstill_velocity_m_per_s;
}

bool ServoCycle::outside_soft_limits(double position_m) const noexcept {
  return position_m < settings_.soft_limit_min_m || position_m > settings_.soft_limit_max_m;
}

void ServoCycle::end_program() noexcept {
  running_ = nullptr;
  mailbox_.program_.set_current(nullptr);
  if (mailbox_.jogging_.load(std::memory_order_relaxed)) {
    mailbox_.jog_token_.store(CycleMailbox::kJogStopped, std::memory_order_release);
    mailbox_.jogging_.store(false, std::memory_order_release);
  }
}

void ServoCycle::begin_stop(const control::StopLimits& limits, bool quick) noexcept {
  stop_profile_ = control::StopProfile::plan(reference_, limits);
  stop_start_cycle_ = reference_cycle_;
  status_.stopping = true;
  stop_quick_ = quick;
  end_program();
  mailbox_.idle_.store(false, std::memory_order_release);
  ++(quick ? status_.counters.quick_stops : status_.counters.stops);
}

void ServoCycle::leave_experiment() noexcept {
  if (!in_experiment()) return;
  // A pending law other than an experiment is the service law already.
  status_.mode = requested_mode_ = service_mode_;
  status_.mode_change_pending = false;
  experiment_coil_set_ = requested_coil_set_ = 0;
  experiment_delta_rad_ = requested_delta_rad_ = 0.0;
}

void ServoCycle::latch(Fault fault) noexcept {
  // Whatever the fault, an experiment ends here: a quick stop is driven by
  // the service law, and a later enable starts in it.
  leave_experiment();
  if (status_.state == ServoState::kFault) {  // the first reason stays
    // A fault that distrusts the feedback ends a quick stop under way.
    if (status_.fault_reaction_running && reaction(fault) == FaultReaction::kZeroSetpoints) {
      status_.fault_reaction_running = status_.stopping = false;
      mailbox_.idle_.store(true, std::memory_order_release);
    }
    return;
  }
  const bool driving = status_.state == ServoState::kEnabled && !status_.enabling;
  status_.state = ServoState::kFault;
  status_.enabling = false;
  status_.fault = fault;
  status_.fault_cycle = cycle_;
  mailbox_.restricted_.store(false, std::memory_order_release);
  const bool moving = running_ != nullptr || status_.stopping || homing_moves();
  abort_homing();
  const bool plausible = have_position_ && std::abs(reference_.position_m - position_m_) <=
                                               kPlausibleErrorFactor * settings_.following_error_limit_m;
  status_.fault_reaction_running = false;
  const bool law_ready = laws_[static_cast<std::size_t>(status_.mode)] != nullptr;
  if (driving && moving && plausible && law_ready && reaction(fault) == FaultReaction::kQuickStop) {
    begin_stop(settings_.quick_stop_limits, true);
    status_.fault_reaction_running = true;
  } else {
    status_.stopping = false;
    end_program();
  }
  if (!status_.fault_reaction_running) mailbox_.idle_.store(true, std::memory_order_release);
}

void ServoCycle::adopt_offers() noexcept {
  // Laws change only at standstill (or when the axis is not driven).
  if (status_.state != ServoState::kEnabled || at_standstill()) {
    for (std::size_t m = 0; m < mailbox_.laws_.size(); ++m) {
      if (const CommutationLaw* law = mailbox_.laws_[m].adopt()) laws_[m] = law;
    }
    if (status_.mode_change_pending) {
      status_.mode = requested_mode_;
      experiment_coil_set_ = requested_coil_set_;
      experiment_delta_rad_ = requested_delta_rad_;
      status_.mode_change_pending = false;
    }
  }
  if (const control::MoveProgram* offered = mailbox_.program_.adopt()) {
    // Taken once: a later program at a reused address is never a jog.
    const bool jog = offered == mailbox_.jog_offer_.exchange(nullptr, std::memory_order_acq_rel);
    // The daemon decided against the state it last saw; this is the state now.
    // Every offer is a move: enabled and at rest, as the command table's row
    // of move_to says; in restricted mode only one that ends inside the soft limits.
    CommandResult result = check_legal(CommandKind::kMoveTo, status_.state, running_ == nullptr && !status_.stopping);
    if (result == CommandResult::kAccepted) {
      // While homing, and while an enable waits to find the commutation
      // (the axis moves before the loop closes), nothing else moves it.
      if (status_.homing != HomingPhase::kIdle || (status_.enabling && !status_.commutation_found)) {
        result = CommandResult::kRejectedHoming;
      } else if (!jog && !status_.homed) {
        result = CommandResult::kRejectedNotHomed;
      } else if (mailbox_.restricted_.load(std::memory_order_relaxed) && outside_soft_limits(offered->end_m())) {
        result = CommandResult::kRejectedRestricted;
      } else if (std::abs(offered->start_m() - hold_m_) > kProgramStartTolerance_m) {
        result = CommandResult::kRejectedStartMoved;
      } else {
        result = jog ? CommandResult::kJogStarted : CommandResult::kProgramPosted;
      }
    }
    status_.last_offer_result = result;
    mailbox_.offers_decided_.fetch_add(1, std::memory_order_acq_rel);
    if (is_accepted(result)) {
      running_ = offered;
      program_start_cycle_ = cycle_;
      mailbox_.idle_.store(false, std::memory_order_release);
      if (jog) {
        jog_token_seen_ = mailbox_.jog_token_.load(std::memory_order_acquire);
        jog_renewed_cycle_ = cycle_;
        mailbox_.jogging_.store(true, std::memory_order_release);
      }
    } else {
      mailbox_.program_.set_current(running_);
      ++status_.counters.programs_rejected;
    }
  }
}

can::Frame ServoCycle::begin_cycle(const CycleStart& start) noexcept {
  // A loop that did not run for long (a stall, SIGSTOP) faults before this
  // cycle drives anything, so the cycle already reacts.
  if (start.wakeup_gap_s > settings_.stall_limit_s) latch(Fault::kLoopStalled);
  if (start.previous_overran) {
    ++status_.counters.overruns;
    if (++consecutive_overruns_ >= settings_.overrun_limit) latch(Fault::kRepeatedOverruns);
  } else {
    consecutive_overruns_ = 0;
  }
  ++cycle_;
  ++status_.counters.cycles;
  sync_time_ns_ = start.sync_time_ns;
  // The last period's setpoints may have missed the drive: dropped after an
  // overrun, or a period without a SYNC.
  previous_period_lost_ = start.previous_overran || start.wakeup_gap_s > 1.5 * settings_.period_s;
  drive_fresh_ = force_fresh_ = false;
  adopt_offers();
  can::Frame sync;
  can::encode_sync(sync_counter_, sync);
  sync_counter_ = can::next_sync_counter(sync_counter_);
  ++status_.counters.frames_sent;
  return sync;
}

void ServoCycle::zero_setpoints() noexcept {
  compensation_.reset();
  setpoints_.setpoints.fill({});
  setpoints_.currents.fill({});
  commanded_.setpoints.fill({});
  commanded_.currents.fill({});
  record_.damping_engaged = false;
  record_.current_square_sum_A2 = 0.0;
}

void ServoCycle::commutate(double position_m, double velocity_m_per_s, double force_N) noexcept {
  const int coil_sets = settings_.protocol.coil_sets;
  const Wrench desired(force_N, 0.0, 0.0);
  record_.Fy_star_N = desired.x();
  record_.Fx_star_N = desired.y();
  record_.Tz_star_Nm = desired.z();
  // The currents are wanted where the axis will be when the drive's current
  // loop has delivered them, 1/ω_c ahead (0 without drive.current_loop).
  const double lead_position_m = position_m + velocity_m_per_s * compensation_.lead_s();
  commanded_.setpoints.fill({});
  commanded_.currents.fill({});
  if (status_.mode == CommutationMode::kExperiment) {
    // Algorithms 1 and 2: the whole demand through one coil set at Δ.
    const auto l = static_cast<std::size_t>(experiment_coil_set_ - 1);
    const DriveSetpoint setpoint{force_N, experiment_delta_rad_};
    const Eigen::Vector2d i = drive_phase_currents(settings_.drive, setpoint, position_m, settings_.pole_pitch_m);
    commanded_.setpoints[l] = setpoint;
    commanded_.currents[l] = {i.x(), i.y()};
    record_.damping_engaged = false;
    record_.current_square_sum_A2 = i.squaredNorm() + (i.x() + i.y()) * (i.x() + i.y());
    if (compensation_.active()) {
      // The back-EMF of every coil set, driven or not, with the gains of
      // the law in service (its currents are replaced below): the drive's
      // nominal law's before anything is calibrated; commissioning
      // identifies on experiments run with a law of its first pass
      // (docs/commutation.md, "The drive's current loop").
      if (const CommutationLaw* service = laws_[static_cast<std::size_t>(service_mode_)]) {
        service->commutate(lead_position_m, desired, commutation_);
      } else {
        const ClassicalCoilSet nominal{settings_.drive.motor_constant_N_per_A, settings_.drive.phase_offset_rad, 0.0, 0.0};
        const Eigen::Vector2d gain = classical_gain(nominal, lead_position_m, settings_.pole_pitch_m).row(0).transpose();
        commutation_.driving_gain_N_per_A.resize(2 * coil_sets);
        for (int k = 0; k < coil_sets; ++k) commutation_.driving_gain_N_per_A.segment<2>(2 * k) = gain;
      }
      commutation_.currents_A.setZero();
      commutation_.currents_A.segment<2>(2 * static_cast<Eigen::Index>(l)) =
          drive_phase_currents(settings_.drive, setpoint, lead_position_m, settings_.pole_pitch_m);
    }
  } else {
    const CommutationLaw* law = laws_[static_cast<std::size_t>(status_.mode)];
    law->commutate(lead_position_m, desired, commutation_);
    for (int l = 0; l < coil_sets; ++l) {
      const auto s = static_cast<std::size_t>(l);
      commanded_.setpoints[s] = commutation_.setpoints[s];
      commanded_.currents[s] = {commutation_.currents_A[2 * l], commutation_.currents_A[2 * l + 1]};
    }
    record_.damping_engaged = commutation_.damping_engaged;
    record_.current_square_sum_A2 = commutation_.current_square_sum_A2;
    if (commutation_.damping_engaged) ++status_.counters.damping_cycles;
  }
  setpoints_.setpoints = commanded_.setpoints;
  setpoints_.currents = commanded_.currents;
  if (compensation_.active()) {
    // The references that make the drive's loop deliver the currents, as
    // setpoints at the position the drive commutates at now.
    compensation_.references(commutation_.currents_A, commutation_.driving_gain_N_per_A, velocity_m_per_s,
                             references_A_);
    for (int l = 0; l < coil_sets; ++l) {
      const auto s = static_cast<std::size_t>(l);
      const auto reference_A = references_A_.segment<2>(2 * l);
      setpoints_.setpoints[s] = setpoint_from_currents(settings_.drive, position_m, settings_.pole_pitch_m,
                                                       reference_A, settings_.phase_convention);
      setpoints_.currents[s] = {reference_A.x(), reference_A.y()};
    }
  }
  shift_to_drive_frame();
  for (int l = 0; l < coil_sets; ++l) {
    const auto s = static_cast<std::size_t>(l);
    const DriveSetpoint& setpoint = setpoints_.setpoints[s];
    const PhaseCurrentSetpoint& currents = setpoints_.currents[s];
    if (!std::isfinite(setpoint.magnitude_N) || !std::isfinite(setpoint.delta_rad) ||
        !std::isfinite(currents.ia_A) || !std::isfinite(currents.ib_A)) {
      latch(Fault::kCommutationNotFinite);
    }
  }
}

std::span<const can::Frame> ServoCycle::end_cycle(double time_s, const BusReport& bus) noexcept {
  // A bus fault known before the setpoints are built already zeroes them.
  report_bus(bus);
  account_feedback();  // servo_cycle_feedback.cpp
  check_soft_limits();
  record_.force_limited = false;
  const auto enabled = [&] { return status_.state == ServoState::kEnabled || status_.fault_reaction_running; };
  if (enabled() && !status_.enabling && status_.homing == HomingPhase::kFinding) {
    find_commutation();
  } else if (enabled() && !status_.enabling) {
    drive();
  } else if (enabled()) {
    wait_for_drive();
  } else {
    follow_axis();
  }
  // What the step left: a fault it latched, a reaction it ended.
  if (!enabled() || status_.enabling) zero_setpoints();
  const std::size_t count = encode_setpoints(enabled());
  fill_record(time_s);
  if (homing_complete_) finish_homing();
  return {frames_.data(), count};
}

void ServoCycle::check_soft_limits() noexcept {
  if (have_position_ && mailbox_.restricted_.load(std::memory_order_relaxed)) {
    // Restricted mode: back inside ends it; farther out than where it was
    // enabled (by more than the following-error limit) latches.
    if (!outside_soft_limits(position_m_)) {
      mailbox_.restricted_.store(false, std::memory_order_release);
    } else if (position_m_ < restricted_min_m_ || position_m_ > restricted_max_m_ || status_.state != ServoState::kEnabled) {
      latch(Fault::kPositionOutOfRange);
    }
  } else if (have_position_ && status_.homed && outside_soft_limits(position_m_)) {
    latch(Fault::kPositionOutOfRange);
  }
}

void ServoCycle::drive() noexcept {
  control::ReferenceSample now{hold_m_, 0.0, 0.0, 0.0};
  control::ReferenceSample next = now;
  // The feedforward's samples, the drive's lag ahead (force_lag_s).
  control::ReferenceSample ahead = now, ahead_next = now;
  // Now, the one-sample preview, and both the lag ahead, from a program or a stop.
  const auto sample = [&](const auto& profile, double t) {
    const double lag_s = settings_.force_lag_s();
    now = profile.sample(t);
    next = profile.sample(t + settings_.period_s);
    ahead = profile.sample(t + lag_s);
    ahead_next = profile.sample(t + settings_.period_s + lag_s);
  };
  if (running_ != nullptr && mailbox_.jogging_.load(std::memory_order_relaxed)) {
    // A jog without renewal for jog_timeout_s stops; a renewal that comes
    // while the cycle decides wins (the exchange fails) and is seen next cycle.
    std::int64_t token = mailbox_.jog_token_.load(std::memory_order_acquire);
    if (token != jog_token_seen_) {
      jog_token_seen_ = token;
      jog_renewed_cycle_ = cycle_;
    } else if (static_cast<double>(cycle_ - jog_renewed_cycle_) * settings_.period_s > settings_.jog_timeout_s &&
               mailbox_.jog_token_.compare_exchange_strong(token, CycleMailbox::kJogStopped, std::memory_order_acq_rel)) {
      ++status_.counters.jog_timeouts;
      begin_stop(settings_.stop_limits, false);
    }
  }
  if (running_ != nullptr) {
    const double t = static_cast<double>(cycle_ - program_start_cycle_) * settings_.period_s;
    sample(*running_, t);
    record_.program_time_s = t;
    if (t >= running_->duration_s()) {
      hold_m_ = running_->end_m();
      mailbox_.hold_position_m_.store(hold_m_, std::memory_order_release);
      end_program();
      mailbox_.idle_.store(true, std::memory_order_release);
    }
  } else if (homing_moves()) {
    sample(search_, static_cast<double>(cycle_ - search_start_cycle_) * settings_.period_s);
    watch_search(now);
  } else if (status_.stopping) {
    const double t = static_cast<double>(cycle_ - stop_start_cycle_) * settings_.period_s;
    sample(stop_profile_, t);
    if (t >= stop_profile_.duration_s()) {
      // At rest: hold there; a fault reaction ends with zero setpoints; a
      // homing moves the position frame at the end of this cycle.
      hold_m_ = stop_profile_.rest_position_m();
      mailbox_.hold_position_m_.store(hold_m_, std::memory_order_release);
      status_.stopping = false;
      status_.fault_reaction_running = false;
      homing_complete_ = status_.homing == HomingPhase::kStopping;
      if (!homing_complete_) mailbox_.idle_.store(true, std::memory_order_release);
    }
  }
  reference_ = now;
  reference_cycle_ = cycle_;
  approach_guard(now, next);
  double force = controller_.update(now, position_m_, ahead, ahead_next);
  if (pushing_to_hard_stop()) {
    // Against the hard stop the force is what homing allows, by design:
    // neither a saturation nor (below its limit) a following-error fault.
    force = std::clamp(force, -settings_.homing.hard_stop_force_N, settings_.homing.hard_stop_force_N);
  }
  record_.r_m = now.position_m;
  record_.r_dot_m_per_s = now.velocity_m_per_s;
  record_.r_ddot_m_per_s2 = now.acceleration_m_per_s2;
  record_.e_m = now.position_m - position_m_;
  record_.u_fb_N = controller_.last_feedback_N();
  record_.u_ff_N = controller_.last_feedforward_N();
  if (!std::isfinite(force)) latch(Fault::kFeedbackNotFinite);
  if (std::abs(record_.e_m) > settings_.following_error_limit_m) latch(Fault::kFollowingError);
  if (std::abs(force) > settings_.force_limit_N) {
    force = std::copysign(settings_.force_limit_N, force);
    record_.force_limited = true;
    ++status_.counters.force_limited_cycles;
    saturated_time_s_ += settings_.period_s;
    if (saturated_time_s_ > settings_.saturation_time_limit_s) latch(Fault::kForceSaturated);
  } else {
    saturated_time_s_ = 0.0;
  }
  record_.F_star_N = force;
  if (status_.state == ServoState::kEnabled || status_.fault_reaction_running) {
    // The laws' position: the axis frame once homed, before that the
    // reading moved by the phase commutation finding found.
    commutate(position_m_ - status_.axis_offset_m + commutation_offset_m_, velocity_estimate_m_per_s_, force);
  }
}

void ServoCycle::approach_guard(const control::ReferenceSample& now, const control::ReferenceSample& next) noexcept {
  // A move whose reference could not quick-stop inside the soft limits from
  // its next sample, or an axis running ahead of it, is quick-stopped from
  // this one. A last resort, so the harder quick stop: admission
  // (decide_move, move_decision.hpp) already guarantees that the ordinary
  // stop, never harder than this one, rests inside.
  if (running_ != nullptr && !mailbox_.restricted_.load(std::memory_order_relaxed)) {
    const double reference_stop_m = control::stopping_position_m(next, settings_.quick_stop_limits);
    // A step whose target lies outside the soft limits (a program no check
    // let in) is stopped a following-error limit before the soft limit, so
    // that the axis, within that of its reference, stays inside too.
    const double t = static_cast<double>(cycle_ - program_start_cycle_) * settings_.period_s;
    const double target_m = step_target_m(*running_, t);
    const double band_m = settings_.following_error_limit_m;
    const bool target_outside = outside_soft_limits(target_m);
    const bool near_limit = reference_stop_m > settings_.soft_limit_max_m - band_m ||
                            reference_stop_m < settings_.soft_limit_min_m + band_m;
    // Within the following-error limit the deviation is the loop's to
    // correct (and kFollowingError's to catch).
    const control::ReferenceSample measured{position_m_, velocity_estimate_m_per_s_, now.acceleration_m_per_s2, 0.0};
    const double axis_stop_m = control::stopping_position_m(measured, settings_.quick_stop_limits);
    const double axis_margin_m = settings_.following_error_limit_m;
    if (reference_stop_m < settings_.soft_limit_min_m - kStopTolerance_m ||
        reference_stop_m > settings_.soft_limit_max_m + kStopTolerance_m || (target_outside && near_limit) ||
        axis_stop_m < settings_.soft_limit_min_m - axis_margin_m ||
        axis_stop_m > settings_.soft_limit_max_m + axis_margin_m) {
      ++status_.counters.guard_stops;
      begin_stop(settings_.quick_stop_limits, true);
    }
  }
}

void ServoCycle::follow_axis() noexcept {
  // Not driving: the reference follows the axis so that enabling is bumpless.
  hold_m_ = position_m_;
  mailbox_.hold_position_m_.store(hold_m_, std::memory_order_release);
  rest_at(position_m_);
}

void ServoCycle::rest_at(double position_m) noexcept {
  record_.r_m = position_m;
  record_.r_dot_m_per_s = record_.r_ddot_m_per_s2 = 0.0;
  record_.e_m = position_m - position_m_;
  record_.u_fb_N = record_.u_ff_N = record_.F_star_N = 0.0;
  record_.Fy_star_N = record_.Fx_star_N = record_.Tz_star_Nm = 0.0;
  reference_ = {position_m, 0.0, 0.0, 0.0};
  reference_cycle_ = cycle_;
}

void ServoCycle::wait_for_drive() noexcept {
  // Enable is sent, the drive does not apply current yet: the hold stays
  // where enable put it (a program offered meanwhile starts there) and a
  // program's clock waits at its start, a jog's silence too.
  if (running_ != nullptr) {
    program_start_cycle_ = cycle_ + 1;
    jog_renewed_cycle_ = cycle_;
  }
  rest_at(hold_m_);
}

std::size_t ServoCycle::encode_setpoints(bool enable) noexcept {
  // Profile magnitude_phase: the (39) setpoints;
  // phase_current: the law's currents as they are (the drive does no
  // commutation of its own). A fault found while encoding sends zero at once.
  setpoints_.coil_sets = settings_.protocol.coil_sets;
  setpoints_.enable = enable;
  setpoints_.clear_fault = clear_drive_fault_;
  // The drive's position latch, armed while the search runs and nothing was latched.
  setpoints_.arm_latch =
      enable && settings_.homing.latches() && status_.homing == HomingPhase::kSearching && !latch_received_;
  setpoints_.latch_on_switch = settings_.homing.method == control::HomingMethod::kReferenceSwitch && !awaiting_index_;
  setpoints_.alive_counter = setpoint_alive_++;
  can::CodecStatus status = can::CodecStatus::kOk;
  std::size_t count = can::encode_setpoints(settings_.protocol, setpoints_, frames_, status);
  if (status != can::CodecStatus::kOk) {
    latch(Fault::kSetpointOutOfRange);
    status_.fault_reaction_running = status_.stopping = false;
    zero_setpoints();
    setpoints_.enable = false;
    count = can::encode_setpoints(settings_.protocol, setpoints_, frames_, status);
  }
  clear_drive_fault_ = false;
  status_.counters.frames_sent += static_cast<std::int64_t>(count);
  return count;
}

void ServoCycle::fill_record(double time_s) noexcept {
  // The commutation's setpoints and currents; with drive.current_loop the
  // frames carry them corrected for the drive's current loop
  // (docs/commutation.md, "The drive's current loop").
  for (std::size_t l = 0; l < static_cast<std::size_t>(setpoints_.coil_sets); ++l) {
    record_.magnitude_N[l] = commanded_.setpoints[l].magnitude_N;
    record_.setpoint_delta_rad[l] = commanded_.setpoints[l].delta_rad;
    record_.ia_A[l] = commanded_.currents[l].ia_A;
    record_.ib_A[l] = commanded_.currents[l].ib_A;
  }
  record_.cycle = cycle_;
  record_.t_s = time_s;
  record_.state = status_.state;
  record_.fault = status_.fault;
  record_.commutation = status_.mode;
  record_.coil_set = status_.mode == CommutationMode::kExperiment ? experiment_coil_set_ : 0;
  record_.delta_rad = status_.mode == CommutationMode::kExperiment ? experiment_delta_rad_ : 0.0;
  record_.y_m = position_m_;
  record_.program_running = running_ != nullptr;
  if (!record_.program_running) record_.program_time_s = 0.0;
  record_.drive_status_word = drive_.status_word;
  record_.stopping = status_.stopping;
  record_.restricted = mailbox_.restricted_.load(std::memory_order_relaxed);
  record_.drive_profile = settings_.protocol.drive_profile;
}

}  // namespace clm::servo
