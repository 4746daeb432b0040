#include "drivers/sim/simulated_nodes.hpp"

#include <stdexcept>
#include <string>

namespace clm::sim {

SimulatedNodes::SimulatedNodes(sim::SimulatedMotor& motor, const can::ProtocolConfig& protocol, double period_s)
    : motor_(&motor), protocol_(protocol), period_s_(period_s) {
  protocol_.validate();
  if (protocol_.drive_profile != motor.parameters().drive.profile) {
    throw std::invalid_argument(std::string("simulated nodes: the CAN protocol's drive profile is ") +
                                name(protocol_.drive_profile) + " but the simulated drive's (drive.profile) is " +
                                name(motor.parameters().drive.profile));
  }
  pending_.coil_sets = protocol.coil_sets;
}

std::size_t SimulatedNodes::on_frame(const can::Frame& frame, std::span<can::Frame> replies) noexcept {
  if (frame.id == can::kSyncId) {
    std::uint8_t counter = 0;
    if (can::decode_sync(frame, counter) != can::CodecStatus::kOk) {
      ++counters_.frames_rejected;
      return 0;
    }
    ++counters_.syncs;
    // Setpoints never outlive their cycle: an incomplete set (an RPDO lost)
    // is dropped, never completed with the next cycle's frames.
    if (received_mask_ != 0) {
      ++counters_.setpoints_incomplete;
      received_mask_ = 0;
    }
    motor_->step(period_s_);
    const sim::SensorFrame sensed = motor_->sense();
    const sim::DriveStatus status = motor_->status();
    std::uint16_t word = 0;
    if (status.enabled()) word |= can::kStatusEnabled;
    if (status.fault()) word |= can::kStatusFault;
    if (status.watchdog()) word |= can::kStatusWatchdogExpired;
    if (status.current_limited()) word |= can::kStatusCurrentLimited;
    if (status.end_stop()) word |= can::kStatusEndStop;
    if (status.latched()) word |= can::kStatusLatched;
    if (status.reference_switch()) word |= can::kStatusReferenceSwitch;
    std::size_t count = 0;
    // The cyclic frames' room is kept; a latch frame goes before them when
    // it fits too (SimulatedNodes::on_frame's contract).
    const std::size_t cyclic = can::has_force_sensor(protocol_) ? 2 : 1;
    double latched_m = 0.0;
    if (motor_->take_latch(latched_m)) {
      // The drive's TPDO2, sent once, in the period of the latch, before its TPDO1.
      const can::DriveLatch latch{latched_m, latch_count_++};
      can::Frame latch_frame;
      if (can::encode_drive_latch(protocol_, latch, latch_frame) != can::CodecStatus::kOk) {
        ++counters_.feedback_not_encoded;
      } else if (replies.size() < cyclic + 1) {
        ++counters_.replies_no_room;
      } else {
        replies[count++] = latch_frame;
      }
    }
    const auto put = [&](const can::Frame& reply) {
      if (count < replies.size()) {
        replies[count++] = reply;
      } else {
        ++counters_.replies_no_room;
      }
    };
    can::Frame reply;
    const can::DriveFeedback drive{sensed.position_m, word, drive_alive_++};
    if (can::encode_drive_feedback(protocol_, drive, reply) == can::CodecStatus::kOk) {
      put(reply);
    } else {
      ++counters_.feedback_not_encoded;
    }
    if (can::has_force_sensor(protocol_)) {  // an axis without one gets no force frame
      const can::ForceFeedback force{sensed.wrench, force_alive_++};
      if (can::encode_force_feedback(protocol_, force, reply) == can::CodecStatus::kOk) {
        put(reply);
      } else {
        ++counters_.feedback_not_encoded;
      }
    }
    return count;
  }
  for (std::size_t index = 0; index < can::setpoint_frame_count(protocol_.coil_sets); ++index) {
    if (frame.id != can::setpoint_id(protocol_, index)) continue;
    if (can::decode_setpoint_frame(protocol_, frame, pending_) != can::CodecStatus::kOk) {
      ++counters_.frames_rejected;
      return 0;
    }
    received_mask_ |= 1u << index;
    const unsigned complete = (1u << can::setpoint_frame_count(protocol_.coil_sets)) - 1;
    if (received_mask_ == complete) {
      if (pending_.clear_fault) motor_->clear_fault();
      motor_->set_latch(pending_.arm_latch, pending_.latch_on_switch ? sim::LatchSource::kReferenceSwitch
                                                                      : sim::LatchSource::kIndex);
      const auto count = static_cast<std::size_t>(protocol_.coil_sets);
      if (protocol_.drive_profile == DriveProfile::kPhaseCurrent) {
        motor_->command_currents(std::span<const PhaseCurrentSetpoint>(pending_.currents.data(), count),
                                 pending_.enable);
      } else {
        motor_->command(std::span<const DriveSetpoint>(pending_.setpoints.data(), count), pending_.enable);
      }
      ++counters_.setpoints_applied;
      received_mask_ = 0;
    }
    return 0;
  }
  return 0;  // not addressed to the nodes
}

}  // namespace clm::sim
