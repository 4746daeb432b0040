#pragma once
// The one conversion each way between clm-servod's in-process messages and
// the clm_lcm wire types. Off the real-time thread only: they allocate.

#include <string>

#include "clm_lcm/servo_command_ack_t.hpp"
#include "clm_lcm/servo_command_t.hpp"
#include "clm_lcm/servo_event_t.hpp"
#include "clm_lcm/servo_state_t.hpp"
#include "clm_lcm/servo_status_t.hpp"
#include "daemon/servo/command.hpp"
#include "daemon/servo/cycle_record.hpp"
#include "daemon/telemetry/messages.hpp"

namespace clm::telemetry {

/// A record as servo_state_t; a utime of 0 becomes wall_clock_utime(). The
/// in-process-only fields (fault, drive_status_word) are not sent. Throws
/// std::logic_error when coil_sets is outside 0..kMaxCoilSets (a caller's bug).
clm_lcm::servo_state_t to_message(const servo::CycleRecord& record);
/// A received servo_state_t as a record (fault and drive_status_word at their
/// defaults). Throws std::invalid_argument naming the field when coil_sets is
/// outside 0..kMaxCoilSets, an array is shorter than coil_sets, or
/// commutation or state is not a known value.
servo::CycleRecord to_record(const clm_lcm::servo_state_t& message);

// A sample's utime of 0 becomes wall_clock_utime().
clm_lcm::servo_status_t to_message(const ServoStatusSample& sample, std::int64_t telemetry_dropped);
clm_lcm::servo_event_t to_message(const ServoEventSample& sample);
/// The ack of the daemon driving `axis` in run `session`.
clm_lcm::servo_command_ack_t to_message(const ServoCommandAck& ack, std::string_view axis, std::int64_t session);

/// Checks a received command and copies it into `out`. Returns "" when it is
/// well-formed, else the one-line reason to send back in the ack: unknown
/// command, a non-finite number, an unknown commutation mode, a coil set
/// outside 1..kMaxCoilSets, an empty or too long (> 255 characters) path.
/// Limits that depend on the motor or on files (stroke, L, positive move
/// limits, model kinds) are ServoDaemon::submit's to check.
std::string to_command(const clm_lcm::servo_command_t& message, servo::Command& out);
/// The one mapping of a command to the wire, to_command's inverse: the
/// fields its kind uses, every other field zero or empty (a client builds the
/// servo::Command the daemon executes and sends this).
clm_lcm::servo_command_t to_message(const servo::Command& command);

}  // namespace clm::telemetry
