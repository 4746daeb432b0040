// The feedback half of the servo cycle: frames received during a cycle
// (alive counters, lateness, duplicates, rejected frames), overruns and the
// bus state reported by the loop. The reference, the position loop and the
// setpoints are in servo_cycle.cpp.
#include "daemon/servo/servo_cycle.hpp"

namespace clm::servo {

void ServoCycle::track_alive(std::uint8_t counter, std::uint8_t& last, bool& known, int& unseen, bool late,
                             Fault jump_fault) noexcept {
  // `unseen` frames of the stream are owed since `last`: a timely frame must
  // be the one after them, a late one must be one of them.
  if (known) {
    const int step = static_cast<std::uint8_t>(counter - last);
    const bool in_sequence = late ? (step >= 1 && step <= unseen) : step == unseen + 1;
    if (!in_sequence) latch(jump_fault);
    unseen = in_sequence && late ? unseen - step : 0;
  } else {
    unseen = 0;
  }
  last = counter;
  known = true;
}

void ServoCycle::on_frame(const drivers::ReceivedFrame& received) noexcept {
  ++counters_.frames_received;
  const can::Frame& frame = received.frame;
  const bool late = received.timestamp_ns < sync_time_ns_;
  if (frame.id == can::drive_feedback_id(settings_.protocol)) {
    can::DriveFeedback feedback;
    if (can::decode_drive_feedback(settings_.protocol, frame, feedback) != can::CodecStatus::kOk) {
      ++counters_.frames_rejected;
      drive_rejected_ = true;
      return;
    }
    if (drive_fresh_ && feedback.alive_counter == drive_alive_) {
      ++counters_.frames_duplicate;
      return;
    }
    track_alive(feedback.alive_counter, drive_alive_, drive_alive_known_, drive_unseen_, late, Fault::kEncoderAliveJump);
    if (late) {
      // Belongs to an earlier cycle, which counted it missing; it does not
      // end the run of cycles without a timely frame either.
      ++counters_.frames_late;
      return;
    }
    drive_ = feedback;
    drive_fresh_ = true;
  } else if (frame.id == can::force_feedback_id(settings_.protocol)) {
    can::ForceFeedback feedback;
    if (can::decode_force_feedback(settings_.protocol, frame, feedback) != can::CodecStatus::kOk) {
      ++counters_.frames_rejected;
      force_rejected_ = true;
      return;
    }
    if (force_fresh_ && feedback.alive_counter == force_alive_) {
      ++counters_.frames_duplicate;
      return;
    }
    track_alive(feedback.alive_counter, force_alive_, force_alive_known_, force_unseen_, late, Fault::kForceAliveJump);
    if (late) {
      ++counters_.frames_late;
      return;
    }
    force_ = feedback;
    force_fresh_ = true;
  } else {
    ++counters_.frames_rejected;
  }
}

void ServoCycle::report_overrun(bool overran) noexcept {
  if (!overran) {
    consecutive_overruns_ = 0;
    return;
  }
  ++counters_.overruns;
  if (++consecutive_overruns_ >= settings_.overrun_limit) latch(Fault::kRepeatedOverruns);
}

void ServoCycle::report_bus(drivers::BusState bus_state, bool send_failed) noexcept {
  if (bus_state == drivers::BusState::kBusOff) latch(Fault::kBusOff);
  if (bus_state == drivers::BusState::kErrorPassive) latch(Fault::kBusErrorPassive);
  if (send_failed) latch(Fault::kSendFailed);
}

}  // namespace clm::servo
