// Homing in the servo cycle (docs/servod.md, "Homing"): commutation finding
// with the loop open, then the search with the loop closed on the drive's
// own law until the drive latches its reference, then the position frame
// moved to it. No allocation, lock, throw or log.

#include <cmath>

#include "commutation/transform.hpp"
#include "daemon/servo/servo_cycle.hpp"

namespace clm::servo {
namespace {

constexpr double kTwoPi = 6.28318530717958647692;
// A latched reading may lie this far outside the readings of the period it
// came in (the encoder's delay and interpolation error, the mode between
// read head and motor side); a latch farther out is not one this search made.
constexpr double kLatchSpanMargin_m = 1e-5;

}  // namespace

bool ServoCycle::needs_homing(CommutationMode mode) const noexcept {
  // The drive's own law is a function of the electrical angle alone, which
  // commutation finding gives; every other law is a function of position.
  return mode != CommutationMode::kOriginal;
}

CommandResult ServoCycle::start_with(CommutationMode mode) noexcept {
  if (status_.homed || !needs_homing(mode)) return request_mode(mode);
  if (mode == CommutationMode::kExperiment) return CommandResult::kRejectedInvalid;
  if (laws_[static_cast<std::size_t>(mode)] == nullptr) return CommandResult::kRejectedNoLaw;
  mode_after_homing_ = mode;
  return CommandResult::kAccepted;
}

CommandResult ServoCycle::home() noexcept {
  if (status_.homing != HomingPhase::kIdle) return CommandResult::kRejectedHoming;
  if (!settings_.homing.incremental()) return CommandResult::kAccepted;  // an absolute encoder: homed from the start
  if (status_.state == ServoState::kEnabled) {
    if (running_ != nullptr || status_.stopping) return CommandResult::kRejectedBusy;
    if (status_.enabling) {
      home_requested_ = true;
      return CommandResult::kAccepted;
    }
    begin_search();
    return CommandResult::kAccepted;
  }
  const CommandResult enabled = enable();
  if (enabled == CommandResult::kAccepted) home_requested_ = true;
  return enabled;
}

void ServoCycle::after_enable() noexcept {
  if (!status_.commutation_found) {
    const double total_force_N = settings_.homing.finding.force_N * settings_.protocol.coil_sets;
    finder_.start(settings_.homing.finding, total_force_N, settings_.machine.mass_kg, settings_.period_s,
                  drive_.position_m);
    status_.homing = HomingPhase::kFinding;
    return;
  }
  if (home_requested_) begin_search();
}

void ServoCycle::find_commutation() noexcept {
  // The loop is open: the reference follows the axis, so that the loop
  // closes bumpless where finding leaves it.
  hold_m_ = position_m_;
  mailbox_.hold_position_m_.store(hold_m_, std::memory_order_release);
  rest_at(position_m_);
  const control::FindingSetpoint test = finder_.update(drive_.position_m, previous_period_lost_);
  switch (finder_.outcome()) {
    case control::FindingOutcome::kRunning: break;
    case control::FindingOutcome::kFound:
      status_.found_phase_rad = finder_.phase_rad();
      commutation_offset_m_ = finder_.phase_rad() * settings_.pole_pitch_m / kTwoPi;
      status_.commutation_found = true;
      status_.homing = HomingPhase::kIdle;
      controller_.reset();
      if (home_requested_) begin_search();
      return;
    case control::FindingOutcome::kMovedTooFar: latch(Fault::kFindingMotion); return;
    case control::FindingOutcome::kNoResponse:
    case control::FindingOutcome::kInconsistent: latch(Fault::kCommutationNotFound); return;
  }
  // The doublet through the drive's own law on its raw reading, every coil set alike.
  const int coil_sets = settings_.protocol.coil_sets;
  commanded_.setpoints.fill({});
  commanded_.currents.fill({});
  double square_sum_A2 = 0.0;
  for (int l = 0; l < coil_sets; ++l) {
    const auto s = static_cast<std::size_t>(l);
    const DriveSetpoint setpoint{test.magnitude_N, test.delta_rad};
    const Eigen::Vector2d i = drive_phase_currents(settings_.drive, setpoint, drive_.position_m, settings_.pole_pitch_m);
    commanded_.setpoints[s] = setpoint;
    commanded_.currents[s] = {i.x(), i.y()};
    square_sum_A2 += i.squaredNorm() + (i.x() + i.y()) * (i.x() + i.y());
  }
  record_.current_square_sum_A2 = square_sum_A2;
  record_.damping_engaged = false;
  setpoints_.setpoints = commanded_.setpoints;
  setpoints_.currents = commanded_.currents;
}

void ServoCycle::begin_search() noexcept {
  home_requested_ = false;
  // The switch's edge is approached from outside, in the search direction,
  // always: an axis that starts inside the switch first moves out of it.
  const bool inside_switch =
      settings_.homing.method == control::HomingMethod::kReferenceSwitch && status_.drive.reference_switch;
  search_from(hold_m_, inside_switch ? -settings_.homing.direction : settings_.homing.direction);
  latch_received_ = latch_checked_ = latch_in_span_ = homing_complete_ = awaiting_index_ = search_again_ = false;
  latch_frame_wait_ = 0;
  status_.homing = inside_switch ? HomingPhase::kLeavingSwitch : HomingPhase::kSearching;
  mailbox_.idle_.store(false, std::memory_order_release);
}

void ServoCycle::search_from(double position_m, int direction) noexcept {
  search_ = control::SearchProfile::plan(position_m, direction * settings_.homing.search_velocity_m_per_s,
                                         settings_.stop_limits);
  search_start_cycle_ = cycle_ + 1;
}

void ServoCycle::stop_at_reference(const control::ReferenceSample& now, double reading_m) noexcept {
  // The reference in the encoder's frame is known: stop, then move the frame.
  pending_offset_m_ = settings_.homing.reference_position_m - reading_m;
  stop_search(now);
}

void ServoCycle::stop_search(const control::ReferenceSample& now) noexcept {
  status_.homing = HomingPhase::kStopping;
  reference_ = now;
  reference_cycle_ = cycle_;
  begin_stop(settings_.stop_limits, false);
}

void ServoCycle::watch_search(const control::ReferenceSample& now) noexcept {
  bool decided = false;
  if (status_.homing == HomingPhase::kLeavingSwitch) {
    decided = !status_.drive.reference_switch;
    if (decided) {
      // Out of the switch: stop, and search again from there (finish_homing).
      search_again_ = true;
      stop_search(now);
    }
  } else {
    decided = settings_.homing.method == control::HomingMethod::kHardStop ? watch_hard_stop(now) : watch_latch(now);
  }
  const bool bounded = status_.homing == HomingPhase::kSearching || status_.homing == HomingPhase::kLeavingSwitch;
  if (!decided && bounded && std::abs(now.position_m - search_.start_m()) > settings_.homing.search_distance_m) {
    latch(Fault::kHomingNotFound);
  }
}

bool ServoCycle::watch_hard_stop(const control::ReferenceSample& now) noexcept {
  if (status_.homing == HomingPhase::kBackingOff) {
    if (std::abs(now.position_m - contact_m_) < settings_.homing.back_off_m) return true;
    stop_at_reference(now, contact_reading_m_);
    return true;
  }
  if (std::abs(now.position_m - position_m_) <= settings_.homing.hard_stop_following_error_m) return false;
  // The reference runs on, the axis stands: it met the stop. That reading
  // is the reference; the search turns back from where the axis is.
  contact_m_ = position_m_;
  contact_reading_m_ = position_m_ - status_.axis_offset_m;
  status_.homing = HomingPhase::kBackingOff;
  search_from(position_m_, -settings_.homing.direction);
  return true;
}

bool ServoCycle::watch_latch(const control::ReferenceSample& now) noexcept {
  if (latch_received_ && !latch_checked_) {
    // The frame is taken as the drive's only if it names a reading between
    // this period's and the last (widened by a period's search and the
    // margin), and the drive's own status says Latched within the frame limit.
    latch_checked_ = true;
    const double reading_m = position_m_ - status_.axis_offset_m;
    const double previous_m = previous_position_m_ - status_.axis_offset_m;
    const double margin_m = settings_.homing.search_velocity_m_per_s * settings_.period_s + kLatchSpanMargin_m;
    latch_in_span_ = latched_reading_m_ >= std::min(reading_m, previous_m) - margin_m &&
                     latched_reading_m_ <= std::max(reading_m, previous_m) + margin_m;
    latch_frame_wait_ = 0;
  }
  if (latch_received_ && !latch_in_span_) {
    latch(Fault::kLatchInvalid);
    return true;
  }
  if (latch_received_ && status_.drive.latched) {
    if (settings_.homing.index_in_switch && !awaiting_index_) {
      // The switch's edge says which mark: the latch goes over to the index
      // (its source changes, which re-arms it) and the search goes on.
      awaiting_index_ = true;
      latch_received_ = latch_checked_ = false;
      latch_frame_wait_ = 0;
      return true;
    }
    stop_at_reference(now, latched_reading_m_);
    return true;
  }
  // The frame and the drive's Latched come together; either alone for
  // longer than the frame limit is not this search's latch.
  if ((latch_received_ || status_.drive.latched) && ++latch_frame_wait_ > settings_.missing_frame_limit) {
    latch(Fault::kLatchInvalid);
    return true;
  }
  return false;
}

void ServoCycle::finish_homing() noexcept {
  if (search_again_) {
    // At rest outside the reference switch: the search proper.
    begin_search();
    return;
  }
  // At rest: every position the cycle keeps moves with the frame, so the
  // loop sees no step.
  const double shift_m = pending_offset_m_ - status_.axis_offset_m;
  status_.axis_offset_m = pending_offset_m_;
  commutation_offset_m_ = pending_offset_m_;
  position_m_ += shift_m;
  previous_position_m_ += shift_m;
  hold_m_ += shift_m;
  reference_.position_m += shift_m;
  mailbox_.hold_position_m_.store(hold_m_, std::memory_order_release);
  status_.homed = true;
  status_.homing = HomingPhase::kIdle;
  homing_complete_ = false;
  mailbox_.idle_.store(true, std::memory_order_release);
  if (mode_after_homing_ != CommutationMode::kOriginal) {
    // At rest in the axis frame: the configured law takes over.
    (void)request_mode(mode_after_homing_);
    mode_after_homing_ = CommutationMode::kOriginal;
  }
}

void ServoCycle::abort_homing() noexcept {
  home_requested_ = false;
  homing_complete_ = search_again_ = false;
  status_.homing = HomingPhase::kIdle;
}

void ServoCycle::shift_to_drive_frame() noexcept {
  // The laws take the drive to commutate on the axis frame; it commutates
  // on its raw reading, commutation_offset_m_ behind it.
  if (settings_.protocol.drive_profile != DriveProfile::kMagnitudePhase || commutation_offset_m_ == 0.0) return;
  const double shift_rad = kTwoPi * commutation_offset_m_ / settings_.pole_pitch_m;
  for (int l = 0; l < settings_.protocol.coil_sets; ++l) {
    // Through the transform (20), which puts it into the convention's range.
    DriveSetpoint& setpoint = setpoints_.setpoints[static_cast<std::size_t>(l)];
    setpoint = transform_inverse(transform_forward({setpoint.magnitude_N, setpoint.delta_rad + shift_rad}),
                                 settings_.phase_convention);
  }
}

}  // namespace clm::servo
