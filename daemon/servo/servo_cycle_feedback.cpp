// The feedback half of the servo cycle: frames received during a cycle
// (alive counters, lateness, duplicates, rejected frames), what the cycle
// makes of them (missing frames, the force sensor's warning) and the bus
// state reported by the loop. Overruns and stalls, the reference, the
// position loop and the setpoints are in servo_cycle.cpp.
#include <cmath>

#include "daemon/servo/servo_cycle.hpp"

namespace clm::servo {

bool ServoCycle::track_alive(std::uint8_t counter, std::uint8_t& last, bool& known, int& unseen,
                             bool late) noexcept {
  // `unseen` frames of the stream are owed since `last`: a timely frame must
  // be the one after them, a late one must be one of them.
  bool in_sequence = true;
  if (known) {
    const int step = static_cast<std::uint8_t>(counter - last);
    in_sequence = late ? (step >= 1 && step <= unseen) : step == unseen + 1;
    unseen = in_sequence && late ? unseen - step : 0;
  } else {
    unseen = 0;
  }
  last = counter;
  known = true;
  return in_sequence;
}

void ServoCycle::force_sensor_trouble(Fault reason) noexcept {
  // An experiment measures with the sensor: losing it there is a fault. In
  // service the loop does not use it: a warning, until it is healthy again.
  if (status_.mode == CommutationMode::kExperiment) {
    latch(reason);
    return;
  }
  force_good_ = 0;
  if (status_.force_sensor_warning == Fault::kNone) {
    status_.force_sensor_warning = reason;
    ++status_.counters.force_sensor_losses;
  }
}

void ServoCycle::account_feedback() noexcept {
  // Ride through missing frames up to the limit. A cycle whose frame came
  // late or was rejected counts as one without it; when rejected frames were
  // part of the run, that is the reason given.
  if (drive_fresh_) {
    drive_missed_ = 0;
    drive_rejected_ = false;
  } else {
    ++status_.counters.frames_missing;
    ++drive_unseen_;
    if (++drive_missed_ >= settings_.missing_frame_limit && have_position_) {
      latch(drive_rejected_ ? Fault::kFrameRejected : Fault::kEncoderFrameMissing);
    }
  }
  account_force_feedback();
  if (drive_fresh_) {
    if (!std::isfinite(drive_.position_m)) latch(Fault::kMeasurementNotFinite);
    previous_position_m_ = have_position_ ? position_m_ : drive_.position_m;
    position_m_ = drive_.position_m + status_.axis_offset_m;
    have_position_ = true;
    // The velocity observer: the reference's acceleration over the last
    // period (what the loop asked the axis to do) predicts the change; the
    // position difference, the mean velocity over that period and so the
    // velocity at its middle, corrects it through a first-order filter of
    // time constant kVelocityFilter_s. Following the reference, the estimate
    // has no lag; a step of the reference's acceleration moves it by no more
    // than the axis moves.
    const double period_s = settings_.period_s;
    const double acceleration_m_per_s2 = reference_.acceleration_m_per_s2;
    const double raw_velocity = (position_m_ - previous_position_m_) / period_s;
    const double alpha = period_s / (kVelocityFilter_s + period_s);
    const double middle_m_per_s = velocity_estimate_m_per_s_ + 0.5 * period_s * acceleration_m_per_s2;
    velocity_estimate_m_per_s_ += period_s * acceleration_m_per_s2 + alpha * (raw_velocity - middle_m_per_s);
    react_to_drive(can::drive_signals(drive_.status_word));
  }
}

void ServoCycle::react_to_drive(const drivers::DriveSignals& signals) noexcept {
  status_.drive = signals;
  // The feedback of the cycle that carries the clear request predates it.
  // The most specific reason first: a drive that stops for its watchdog or
  // an end stop sets its fault bit too.
  if (!clear_drive_fault_) {
    if (signals.watchdog_expired) latch(Fault::kDriveWatchdog);
    if (signals.end_stop) latch(Fault::kEndStop);
    if (signals.fault) latch(Fault::kDriveFault);
  }
  // Durations in whole periods, so that a limit of n periods lets n pass.
  const auto periods = [&](double seconds) { return std::llround(seconds / settings_.period_s); };
  if (status_.state != ServoState::kEnabled) {
    current_limited_periods_ = 0;
    return;
  }
  if (signals.current_limited) {
    ++status_.counters.current_limited_cycles;
    if (++current_limited_periods_ > periods(settings_.current_limited_limit_s)) latch(Fault::kDriveCurrentLimited);
  } else {
    current_limited_periods_ = 0;
  }
  // The handshake: enable completes when the drive says so; a drive that
  // stops saying so without a fault of its own is one that no longer applies current.
  if (signals.enabled) {
    if (status_.enabling) {
      status_.enabling = false;
      after_enable();
    }
  } else if (!status_.enabling) {
    latch(Fault::kDriveNotEnabled);
  } else if (++enable_wait_periods_ > periods(settings_.enable_timeout_s)) {
    latch(Fault::kDriveNotEnabled);
  }
}

void ServoCycle::account_force_feedback() noexcept {
  // The record carries this cycle's measurement, or zero and force_measured false.
  const bool measured = force_fresh_ && force_.wrench.allFinite();
  record_.force_measured = measured;
  record_.Fy_N = measured ? force_.wrench.x() : 0.0;
  record_.Fx_N = measured ? force_.wrench.y() : 0.0;
  record_.Tz_Nm = measured ? force_.wrench.z() : 0.0;
  if (!can::has_force_sensor(settings_.protocol)) return;
  if (measured) {
    force_missed_ = 0;
    force_rejected_ = false;
    // Healthy again after missing_frame_limit good cycles in a row.
    if (status_.force_sensor_warning != Fault::kNone && ++force_good_ >= settings_.missing_frame_limit) {
      status_.force_sensor_warning = Fault::kNone;
    }
    return;
  }
  if (force_fresh_) {
    force_sensor_trouble(Fault::kMeasurementNotFinite);
    return;
  }
  ++status_.counters.frames_missing;
  ++force_unseen_;
  if (++force_missed_ >= settings_.missing_frame_limit && have_position_) {
    force_sensor_trouble(force_rejected_ ? Fault::kFrameRejected : Fault::kForceFrameMissing);
  }
}

void ServoCycle::on_frame(const drivers::ReceivedFrame& received) noexcept {
  ++status_.counters.frames_received;
  const can::Frame& frame = received.frame;
  const bool late = received.timestamp_ns < sync_time_ns_;
  if (frame.id == can::drive_feedback_id(settings_.protocol)) {
    can::DriveFeedback feedback;
    if (can::decode_drive_feedback(settings_.protocol, frame, feedback) != can::CodecStatus::kOk) {
      ++status_.counters.frames_rejected;
      drive_rejected_ = true;
      return;
    }
    if (drive_fresh_ && feedback.alive_counter == drive_alive_) {
      ++status_.counters.frames_duplicate;
      return;
    }
    if (!track_alive(feedback.alive_counter, drive_alive_, drive_alive_known_, drive_unseen_, late)) {
      latch(Fault::kEncoderAliveJump);
    }
    if (late) {
      // Belongs to an earlier cycle, which counted it missing; it does not
      // end the run of cycles without a timely frame either.
      ++status_.counters.frames_late;
      return;
    }
    drive_ = feedback;
    drive_fresh_ = true;
  } else if (frame.id == can::drive_latch_id(settings_.protocol)) {
    // The drive's latch frame: taken while a search waits for it, else ignored.
    can::DriveLatch latched;
    if (can::decode_drive_latch(settings_.protocol, frame, latched) != can::CodecStatus::kOk) {
      ++status_.counters.frames_rejected;
      return;
    }
    if (status_.homing == HomingPhase::kSearching && !latch_received_ && std::isfinite(latched.position_m)) {
      latched_reading_m_ = latched.position_m;
      latch_received_ = true;
    }
  } else if (can::has_force_sensor(settings_.protocol) && frame.id == can::force_feedback_id(settings_.protocol)) {
    can::ForceFeedback feedback;
    if (can::decode_force_feedback(settings_.protocol, frame, feedback) != can::CodecStatus::kOk) {
      ++status_.counters.frames_rejected;
      force_rejected_ = true;
      return;
    }
    if (force_fresh_ && feedback.alive_counter == force_alive_) {
      ++status_.counters.frames_duplicate;
      return;
    }
    if (!track_alive(feedback.alive_counter, force_alive_, force_alive_known_, force_unseen_, late)) {
      force_sensor_trouble(Fault::kForceAliveJump);
    }
    if (late) {
      ++status_.counters.frames_late;
      return;
    }
    force_ = feedback;
    force_fresh_ = true;
  } else {
    ++status_.counters.frames_rejected;
  }
}

void ServoCycle::report_bus(const BusReport& bus) noexcept {
  if (bus.state == drivers::BusState::kBusOff) latch(Fault::kBusOff);
  if (bus.state == drivers::BusState::kErrorPassive) latch(Fault::kBusErrorPassive);
  if (bus.send_failed) latch(Fault::kSendFailed);
}

void ServoCycle::sent(const BusReport& bus) noexcept { report_bus(bus); }

}  // namespace clm::servo
