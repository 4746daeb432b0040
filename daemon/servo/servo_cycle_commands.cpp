// The owner's and the command side of the servo cycle: the settings and
// their validation, and the commands the daemon's loop executes between two
// cycles (enable, disable, clear-fault, stops, law requests, run-time
// settings). The cycle itself is in servo_cycle.cpp, the
// feedback it receives in servo_cycle_feedback.cpp.
#include <cmath>
#include <stdexcept>
#include <string>

#include "commutation/model_file.hpp"
#include "daemon/servo/servo_cycle.hpp"

namespace clm::servo {
namespace {

bool valid_limits(const control::StopLimits& limits) noexcept {
  return limits.deceleration_m_per_s2 > 0.0 && std::isfinite(limits.deceleration_m_per_s2) &&
         limits.jerk_m_per_s3 > 0.0 && std::isfinite(limits.jerk_m_per_s3);
}

}  // namespace

void ServoSettings::validate() const {
  const auto require = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
  };
  require(period_s > 0.0 && std::isfinite(period_s), "period_s must be positive");
  require(pole_pitch_m > 0.0, "pole_pitch_m must be positive");
  require(drive.motor_constant_N_per_A > 0.0, "drive motor constant must be positive");
  protocol.validate();
  current_loop.validate();
  require(setpoint_delay_s >= 0.0 && setpoint_delay_s <= MotorDescription::kMaxDelay_s,
          "setpoint_delay_s must lie in 0.." + std::to_string(MotorDescription::kMaxDelay_s) + " s");
  require(soft_limit_max_m > soft_limit_min_m, "soft_limit_max_m must be above soft_limit_min_m");
  require(following_error_limit_m > 0.0, "following_error_limit_m must be positive");
  require(force_limit_N > 0.0, "force_limit_N must be positive");
  require(saturation_time_limit_s >= 0.0, "saturation_time_limit_s must not be negative");
  require(missing_frame_limit >= 1, "missing_frame_limit must be at least 1");
  require(overrun_limit >= 1, "overrun_limit must be at least 1");
  require(stall_limit_s >= 2.0 * period_s && stall_limit_s <= 10.0, "stall_limit_s must be in [2 periods, 10 s]");
  require(enable_timeout_s >= 2.0 * period_s && enable_timeout_s <= 10.0,
          "enable_timeout_s must be in [2 periods, 10 s]");
  require(current_limited_limit_s >= period_s && current_limited_limit_s <= 10.0,
          "current_limited_limit_s must be in [1 period, 10 s]");
  require(standstill_velocity_m_per_s > 0.0, "standstill_velocity_m_per_s must be positive");
  const auto positive = [](double x) { return x > 0.0 && std::isfinite(x); };
  require(positive(motion_limits.velocity_m_per_s) && positive(motion_limits.acceleration_m_per_s2) &&
              positive(motion_limits.jerk_m_per_s3),
          "motion limits must be positive and finite");
  require(valid_limits(stop_limits), "stop limits must be positive and finite");
  require(valid_limits(quick_stop_limits), "quick-stop limits must be positive and finite");
  require(quick_stop_limits.deceleration_m_per_s2 >= stop_limits.deceleration_m_per_s2 &&
              quick_stop_limits.jerk_m_per_s3 >= stop_limits.jerk_m_per_s3,
          "quick-stop deceleration and jerk must not be below the stop's");
  require(recovery_velocity_fraction > 0.0 && recovery_velocity_fraction <= 1.0,
          "recovery_velocity_fraction must be in (0, 1]");
  require(recovery_margin_m >= 0.0 && std::isfinite(recovery_margin_m), "recovery_margin_m must not be negative");
  require(jog_timeout_s > 0.0 && std::isfinite(jog_timeout_s), "jog_timeout_s must be positive");
  homing.validate();
  // The search starts and stops within the stop limits: its velocity must be one a move may have.
  require(homing.search_velocity_m_per_s <= motion_limits.velocity_m_per_s,
          "homing.search_velocity_m_per_s must not exceed motion.velocity_m_per_s");
  // The hard stop is told by the following error, before the fault's limit is.
  require(homing.method != control::HomingMethod::kHardStop ||
              homing.hard_stop_following_error_m < following_error_limit_m,
          "homing.hard_stop_following_error_m must lie below control.following_error_limit_m");
  const std::string outside = control::check_envelope(
      machine, {period_s, soft_limit_min_m, soft_limit_max_m, following_error_limit_m, force_limit_N,
                saturation_time_limit_s, motion_limits, stop_limits, quick_stop_limits, feedforward, pid});
  require(outside.empty(), outside);
}

Tuning ServoSettings::tuning() const noexcept {
  return {pid, feedforward, following_error_limit_m, force_limit_N, saturation_time_limit_s,
          motion_limits, stop_limits, quick_stop_limits};
}

void ServoSettings::apply(const Tuning& tuning) noexcept {
  pid = tuning.pid;
  feedforward = tuning.feedforward;
  following_error_limit_m = tuning.following_error_limit_m;
  force_limit_N = tuning.force_limit_N;
  saturation_time_limit_s = tuning.saturation_time_limit_s;
  motion_limits = tuning.motion_limits;
  stop_limits = tuning.stop_limits;
  quick_stop_limits = tuning.quick_stop_limits;
}

CommandResult ServoCycle::execute(const Command& command) noexcept {
  switch (command.kind) {
    case CommandKind::kEnable: return enable();
    case CommandKind::kDisable: return disable();
    case CommandKind::kClearFault: return clear_fault();
    case CommandKind::kStop: return stop();
    case CommandKind::kQuickStop: return quick_stop();
    case CommandKind::kSetCommutation: return request_mode(command.commutation);
    case CommandKind::kSetExperiment:
      return request_mode(CommutationMode::kExperiment, command.coil_set, command.delta_rad);
    case CommandKind::kLoadFeedforward: set_feedforward(command.feedforward); return CommandResult::kAccepted;
    case CommandKind::kSetParameter: return apply_tuning(command.tuning);
    case CommandKind::kHome: return home();
    default: return CommandResult::kRejectedInvalid;  // not a kind the cycle executes (moves come as offers)
  }
}

void ServoCycle::owner_gone() noexcept {
  // As after a fault (latch): the experiment ends at once, so that the quick
  // stop is driven by the service law, not by one coil set at an offset angle
  // that may not deliver the stop's force.
  leave_experiment();
  quick_stop();
}

CommandResult ServoCycle::enable() noexcept {
  bool recovering = false;
  if (status_.state == ServoState::kFault) {
    // Restricted mode: kPositionOutOfRange with the axis still outside the
    // soft limits, near enough to them, and its stop finished.
    const bool near = have_position_ && std::isfinite(position_m_) &&
                      position_m_ >= settings_.soft_limit_min_m - settings_.recovery_margin_m &&
                      position_m_ <= settings_.soft_limit_max_m + settings_.recovery_margin_m;
    if (status_.fault != Fault::kPositionOutOfRange || status_.fault_reaction_running || !near || !outside_soft_limits(position_m_)) {
      return CommandResult::kRejectedFault;
    }
    recovering = true;
  }
  if (status_.state == ServoState::kEnabled) return CommandResult::kAccepted;
  if (status_.mode != CommutationMode::kExperiment && laws_[static_cast<std::size_t>(status_.mode)] == nullptr) {
    return CommandResult::kRejectedNoLaw;
  }
  if (recovering) {
    status_.fault = Fault::kNone;
    status_.fault_cycle = -1;
    clear_drive_fault_ = true;
    restricted_min_m_ = std::min(settings_.soft_limit_min_m, position_m_ - settings_.following_error_limit_m);
    restricted_max_m_ = std::max(settings_.soft_limit_max_m, position_m_ + settings_.following_error_limit_m);
  }
  mailbox_.restricted_.store(recovering, std::memory_order_release);
  // Bumpless: hold where the axis is, fresh integrator; the loop closes when
  // the drive reports Enabled (react_to_drive).
  status_.state = ServoState::kEnabled;
  status_.enabling = true;
  enable_wait_periods_ = current_limited_periods_ = 0;
  status_.stopping = status_.fault_reaction_running = false;
  reference_ = {position_m_, 0.0, 0.0, 0.0};
  hold_m_ = position_m_;
  mailbox_.hold_position_m_.store(hold_m_, std::memory_order_release);
  controller_.reset();
  saturated_time_s_ = 0.0;
  return CommandResult::kAccepted;
}

CommandResult ServoCycle::disable() noexcept {
  if (status_.state == ServoState::kEnabled) status_.state = ServoState::kDisabled;
  status_.enabling = false;
  abort_homing();
  end_program();
  leave_experiment();
  status_.stopping = status_.fault_reaction_running = false;
  mailbox_.restricted_.store(false, std::memory_order_release);
  mailbox_.idle_.store(true, std::memory_order_release);
  return CommandResult::kAccepted;
}

CommandResult ServoCycle::clear_fault() noexcept {
  if (status_.state != ServoState::kFault) return CommandResult::kAccepted;
  status_.state = ServoState::kDisabled;
  status_.fault = Fault::kNone;
  status_.fault_cycle = -1;
  status_.stopping = status_.fault_reaction_running = false;
  mailbox_.idle_.store(true, std::memory_order_release);
  clear_drive_fault_ = true;  // one cycle with the clear bit to the drive
  drive_missed_ = force_missed_ = 0;
  drive_unseen_ = force_unseen_ = 0;
  drive_rejected_ = force_rejected_ = false;
  consecutive_overruns_ = 0;
  drive_alive_known_ = force_alive_known_ = false;
  return CommandResult::kAccepted;
}

CommandResult ServoCycle::stop() noexcept {
  // Commutation finding runs with the loop open: stopping it is opening the drive.
  if (status_.homing == HomingPhase::kFinding) return disable();
  if (status_.state == ServoState::kEnabled && (running_ != nullptr || homing_moves())) {
    begin_stop(settings_.stop_limits, false);
  }
  abort_homing();
  return CommandResult::kAccepted;
}

CommandResult ServoCycle::quick_stop() noexcept {
  if (status_.homing == HomingPhase::kFinding) return disable();
  if (status_.state == ServoState::kEnabled &&
      (running_ != nullptr || homing_moves() || (status_.stopping && !stop_quick_))) {
    begin_stop(settings_.quick_stop_limits, true);
  }
  abort_homing();
  return CommandResult::kAccepted;
}

CommandResult ServoCycle::request_mode(CommutationMode mode, int coil_set, double delta_rad) noexcept {
  if (mode == CommutationMode::kExperiment) {
    if (coil_set < 1 || coil_set > settings_.protocol.coil_sets || !std::isfinite(delta_rad) ||
        std::abs(delta_rad) > kPi) {
      return CommandResult::kRejectedInvalid;
    }
    // An axis without a force sensor runs experiments for the identification
    // from positions; one whose sensor is lost would record forces of nothing.
    if (can::has_force_sensor(settings_.protocol) && status_.force_sensor_warning != Fault::kNone) {
      return CommandResult::kRejectedNoForceSensor;
    }
  }
  if (needs_homing(mode) && !status_.homed) return CommandResult::kRejectedNotHomed;
  if (mode != CommutationMode::kExperiment && laws_[static_cast<std::size_t>(mode)] == nullptr &&
             !mailbox_.laws_[static_cast<std::size_t>(mode)].pending()) {
    return CommandResult::kRejectedNoLaw;
  }
  requested_mode_ = mode;
  if (mode != CommutationMode::kExperiment) {
    service_mode_ = mode;
    mode_after_homing_ = CommutationMode::kOriginal;  // a law chosen now wins over start_with's
  }
  requested_coil_set_ = mode == CommutationMode::kExperiment ? coil_set : 0;
  requested_delta_rad_ = mode == CommutationMode::kExperiment ? delta_rad : 0.0;
  status_.mode_change_pending = true;
  if (status_.state != ServoState::kEnabled || at_standstill()) {
    status_.mode = requested_mode_;
    experiment_coil_set_ = requested_coil_set_;
    experiment_delta_rad_ = requested_delta_rad_;
    status_.mode_change_pending = false;
    return CommandResult::kAccepted;
  }
  return CommandResult::kDeferred;
}

void ServoCycle::set_feedforward(const control::FeedforwardParameters& parameters) noexcept {
  controller_.set_feedforward(parameters);
  settings_.feedforward = parameters;
}

CommandResult ServoCycle::apply_tuning(const Tuning& tuning) noexcept {
  // At standstill only: no reference is under way whose limits would change.
  if (running_ != nullptr || status_.stopping || mailbox_.program_.pending()) return CommandResult::kRejectedBusy;
  settings_.apply(tuning);
  controller_.set_gains(tuning.pid);  // the integrator keeps its force: no bump at rest
  controller_.set_feedforward(tuning.feedforward);
  return CommandResult::kAccepted;
}

}  // namespace clm::servo
