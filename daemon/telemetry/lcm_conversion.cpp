#include "daemon/telemetry/lcm_conversion.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace clm::telemetry {

using clm_lcm::servo_command_t;
using clm_lcm::servo_state_t;
using clm_lcm::servo_status_t;
using servo::CommandKind;

static_assert(kDriveEnabled == servo_status_t::DRIVE_ENABLED && kDriveFault == servo_status_t::DRIVE_FAULT &&
              kDriveWatchdogExpired == servo_status_t::DRIVE_WATCHDOG_EXPIRED &&
              kDriveCurrentLimited == servo_status_t::DRIVE_CURRENT_LIMITED &&
              kDriveEndStop == servo_status_t::DRIVE_END_STOP && kDriveLatched == servo_status_t::DRIVE_LATCHED &&
              kDriveReferenceSwitch == servo_status_t::DRIVE_REFERENCE_SWITCH);
static_assert(static_cast<int>(servo::HomingPhase::kIdle) == servo_status_t::HOMING_IDLE &&
              static_cast<int>(servo::HomingPhase::kFinding) == servo_status_t::HOMING_FINDING &&
              static_cast<int>(servo::HomingPhase::kSearching) == servo_status_t::HOMING_SEARCHING &&
              static_cast<int>(servo::HomingPhase::kStopping) == servo_status_t::HOMING_STOPPING &&
              static_cast<int>(servo::HomingPhase::kBackingOff) == servo_status_t::HOMING_BACKING_OFF &&
              static_cast<int>(servo::HomingPhase::kLeavingSwitch) == servo_status_t::HOMING_LEAVING_SWITCH);
static_assert(static_cast<int>(CommandKind::kEnable) == servo_command_t::ENABLE);
static_assert(static_cast<int>(CommandKind::kDisable) == servo_command_t::DISABLE);
static_assert(static_cast<int>(CommandKind::kClearFault) == servo_command_t::CLEAR_FAULT);
static_assert(static_cast<int>(CommandKind::kMoveTo) == servo_command_t::MOVE_TO);
static_assert(static_cast<int>(CommandKind::kRunProgram) == servo_command_t::RUN_PROGRAM);
static_assert(static_cast<int>(CommandKind::kSetCommutation) == servo_command_t::SET_COMMUTATION);
static_assert(static_cast<int>(CommandKind::kSetExperiment) == servo_command_t::SET_EXPERIMENT);
static_assert(static_cast<int>(CommandKind::kLoadCalibration) == servo_command_t::LOAD_CALIBRATION);
static_assert(static_cast<int>(CommandKind::kLoadModel) == servo_command_t::LOAD_MODEL);
static_assert(static_cast<int>(CommandKind::kStop) == servo_command_t::STOP);
static_assert(static_cast<int>(CommandKind::kLoadFeedforward) == servo_command_t::LOAD_FEEDFORWARD);
static_assert(static_cast<int>(CommandKind::kTakeControl) == servo_command_t::TAKE_CONTROL);
static_assert(static_cast<int>(CommandKind::kReleaseControl) == servo_command_t::RELEASE_CONTROL);
static_assert(static_cast<int>(CommandKind::kRenewControl) == servo_command_t::RENEW_CONTROL);
static_assert(static_cast<int>(CommandKind::kQuickStop) == servo_command_t::QUICK_STOP);
static_assert(static_cast<int>(CommandKind::kJog) == servo_command_t::JOG);
static_assert(static_cast<int>(CommandKind::kGetParameter) == servo_command_t::GET_PARAMETER);
static_assert(static_cast<int>(CommandKind::kSetParameter) == servo_command_t::SET_PARAMETER);
static_assert(static_cast<int>(CommandKind::kHome) == servo_command_t::HOME);
static_assert(servo::kCommandKinds == servo_command_t::HOME);
static_assert(static_cast<int>(servo::CommutationMode::kOriginal) == servo_state_t::COMMUTATION_ORIGINAL);
static_assert(static_cast<int>(servo::CommutationMode::kClassical) == servo_state_t::COMMUTATION_CLASSICAL);
static_assert(static_cast<int>(servo::CommutationMode::kPgnn) == servo_state_t::COMMUTATION_PGNN);
static_assert(static_cast<int>(servo::CommutationMode::kSpline) == servo_state_t::COMMUTATION_SPLINE);
static_assert(static_cast<int>(servo::CommutationMode::kOracle) == servo_state_t::COMMUTATION_ORACLE);
static_assert(static_cast<int>(servo::CommutationMode::kExperiment) == servo_state_t::COMMUTATION_EXPERIMENT);
static_assert(static_cast<int>(servo::ServoState::kDisabled) == clm_lcm::servo_status_t::STATE_DISABLED);
static_assert(static_cast<int>(servo::ServoState::kEnabled) == clm_lcm::servo_status_t::STATE_ENABLED);
static_assert(static_cast<int>(servo::ServoState::kFault) == clm_lcm::servo_status_t::STATE_FAULT);

// ---- the cycle's record --------------------------------------------------------

clm_lcm::servo_state_t to_message(const servo::CycleRecord& record) {
  if (record.coil_sets < 0 || record.coil_sets > kMaxCoilSets) {
    // A bug in the caller, not a measurement: refuse rather than cut the arrays.
    throw std::logic_error("CycleRecord of cycle " + std::to_string(record.cycle) + ": coil_sets " +
                           std::to_string(record.coil_sets) + " outside 0.." + std::to_string(kMaxCoilSets));
  }
  servo_state_t m;
  m.utime = stamped(record.utime);
  m.cycle = record.cycle;
  m.t_s = record.t_s;
  m.r_m = record.r_m;
  m.r_dot_m_per_s = record.r_dot_m_per_s;
  m.r_ddot_m_per_s2 = record.r_ddot_m_per_s2;
  m.y_m = record.y_m;
  m.e_m = record.e_m;
  m.F_star_N = record.F_star_N;
  m.u_fb_N = record.u_fb_N;
  m.u_ff_N = record.u_ff_N;
  m.Fy_star_N = record.Fy_star_N;
  m.Fx_star_N = record.Fx_star_N;
  m.Tz_star_Nm = record.Tz_star_Nm;
  m.Fy_N = record.Fy_N;
  m.Fx_N = record.Fx_N;
  m.Tz_Nm = record.Tz_Nm;
  m.commutation = static_cast<std::int8_t>(record.commutation);
  m.coil_set = static_cast<std::int8_t>(record.coil_set);
  m.delta_rad = record.delta_rad;
  m.coil_sets = static_cast<std::int8_t>(record.coil_sets);
  const auto count = static_cast<std::size_t>(record.coil_sets);
  m.magnitude_N.assign(record.magnitude_N.begin(), record.magnitude_N.begin() + count);
  m.setpoint_delta_rad.assign(record.setpoint_delta_rad.begin(), record.setpoint_delta_rad.begin() + count);
  m.ia_A.assign(record.ia_A.begin(), record.ia_A.begin() + count);
  m.ib_A.assign(record.ib_A.begin(), record.ib_A.begin() + count);
  m.damping_engaged = record.damping_engaged;
  m.current_square_sum_A2 = record.current_square_sum_A2;
  m.force_limited = record.force_limited;
  m.state = static_cast<std::int8_t>(record.state);
  m.program_running = record.program_running;
  m.program_time_s = record.program_time_s;
  m.restricted = record.restricted;
  m.force_measured = record.force_measured;
  m.drive_profile = static_cast<std::int8_t>(record.drive_profile);
  return m;
}

servo::CycleRecord to_record(const clm_lcm::servo_state_t& m) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
  if (m.coil_sets < 0 || m.coil_sets > kMaxCoilSets) {
    fail("coil_sets " + std::to_string(m.coil_sets) + " outside 0.." + std::to_string(kMaxCoilSets));
  }
  const auto count = static_cast<std::size_t>(m.coil_sets);
  for (const auto& [field, size] : {std::pair{"magnitude_N", m.magnitude_N.size()},
                                    std::pair{"setpoint_delta_rad", m.setpoint_delta_rad.size()},
                                    std::pair{"ia_A", m.ia_A.size()}, std::pair{"ib_A", m.ib_A.size()}}) {
    if (size < count) fail(std::string(field) + " has " + std::to_string(size) + " entries, coil_sets is " + std::to_string(count));
  }
  if (m.commutation < servo_state_t::COMMUTATION_ORIGINAL || m.commutation > servo_state_t::COMMUTATION_EXPERIMENT) {
    fail("commutation " + std::to_string(m.commutation) + " outside 0..5");
  }
  if (m.state < clm_lcm::servo_status_t::STATE_DISABLED || m.state > clm_lcm::servo_status_t::STATE_FAULT) {
    fail("state " + std::to_string(m.state) + " outside 0..2");
  }
  if (m.drive_profile < servo_state_t::DRIVE_PROFILE_MAGNITUDE_PHASE ||
      m.drive_profile > servo_state_t::DRIVE_PROFILE_PHASE_CURRENT) {
    fail("drive_profile " + std::to_string(m.drive_profile) + " outside 0..1");
  }
  servo::CycleRecord r;
  r.utime = m.utime;
  r.cycle = m.cycle;
  r.t_s = m.t_s;
  r.r_m = m.r_m;
  r.r_dot_m_per_s = m.r_dot_m_per_s;
  r.r_ddot_m_per_s2 = m.r_ddot_m_per_s2;
  r.y_m = m.y_m;
  r.e_m = m.e_m;
  r.F_star_N = m.F_star_N;
  r.u_fb_N = m.u_fb_N;
  r.u_ff_N = m.u_ff_N;
  r.Fy_star_N = m.Fy_star_N;
  r.Fx_star_N = m.Fx_star_N;
  r.Tz_star_Nm = m.Tz_star_Nm;
  r.Fy_N = m.Fy_N;
  r.Fx_N = m.Fx_N;
  r.Tz_Nm = m.Tz_Nm;
  r.commutation = static_cast<servo::CommutationMode>(m.commutation);
  r.coil_set = m.coil_set;
  r.delta_rad = m.delta_rad;
  r.coil_sets = m.coil_sets;
  for (std::size_t l = 0; l < count; ++l) {
    r.magnitude_N[l] = m.magnitude_N[l];
    r.setpoint_delta_rad[l] = m.setpoint_delta_rad[l];
    r.ia_A[l] = m.ia_A[l];
    r.ib_A[l] = m.ib_A[l];
  }
  r.damping_engaged = m.damping_engaged;
  r.current_square_sum_A2 = m.current_square_sum_A2;
  r.force_limited = m.force_limited;
  r.state = static_cast<servo::ServoState>(m.state);
  r.program_running = m.program_running;
  r.program_time_s = m.program_time_s;
  r.restricted = m.restricted;
  r.force_measured = m.force_measured;
  r.drive_profile = static_cast<DriveProfile>(m.drive_profile);
  return r;
}

// ---- status, events, acks ------------------------------------------------------

clm_lcm::servo_status_t to_message(const ServoStatusSample& sample, std::int64_t telemetry_dropped) {
  clm_lcm::servo_status_t m;
  m.utime = stamped(sample.utime);
  m.axis = std::string(sample.axis.view());
  m.session = sample.session;
  m.state = sample.state;
  m.fault = sample.fault;
  m.fault_reason = std::string(sample.fault_reason.view());
  m.fault_cycle = sample.fault_cycle;
  m.commutation = sample.commutation;
  m.calibration_file = std::string(sample.calibration.path.view());
  m.calibration_sha256 = std::string(sample.calibration.sha256.view());
  m.pgnn_model_file = std::string(sample.pgnn_model.path.view());
  m.pgnn_model_sha256 = std::string(sample.pgnn_model.sha256.view());
  m.spline_model_file = std::string(sample.spline_model.path.view());
  m.spline_model_sha256 = std::string(sample.spline_model.sha256.view());
  m.feedforward_file = std::string(sample.feedforward.path.view());
  m.feedforward_sha256 = std::string(sample.feedforward.sha256.view());
  m.configuration_file = std::string(sample.configuration.path.view());
  m.configuration_sha256 = std::string(sample.configuration.sha256.view());
  m.motor_file = std::string(sample.motor.path.view());
  m.motor_sha256 = std::string(sample.motor.sha256.view());
  m.wakeup_latency_p50_s = sample.wakeup_latency_p50_s;
  m.wakeup_latency_p99_s = sample.wakeup_latency_p99_s;
  m.wakeup_latency_max_s = sample.wakeup_latency_max_s;
  m.compute_time_p50_s = sample.compute_time_p50_s;
  m.compute_time_p99_s = sample.compute_time_p99_s;
  m.compute_time_max_s = sample.compute_time_max_s;
  m.overruns = sample.overruns;
  m.cycles = sample.cycles;
  std::copy(sample.wakeup_latency_histogram.begin(), sample.wakeup_latency_histogram.end(), m.wakeup_latency_histogram);
  std::copy(sample.compute_time_histogram.begin(), sample.compute_time_histogram.end(), m.compute_time_histogram);
  m.frames_sent = sample.frames_sent;
  m.frames_received = sample.frames_received;
  m.frames_missing = sample.frames_missing;
  m.frames_late = sample.frames_late;
  m.frames_rejected = sample.frames_rejected;
  m.telemetry_dropped = telemetry_dropped;
  m.bus_state = sample.bus_state;
  m.damping_cycles = sample.damping_cycles;
  m.program_running = sample.program_running;
  m.program_time_s = sample.program_time_s;
  m.restricted = sample.restricted;
  m.force_sensor = sample.force_sensor;
  m.force_sensor_warning = sample.force_sensor_warning;
  m.force_sensor_losses = sample.force_sensor_losses;
  m.drive_signals = sample.drive_signals;
  m.enabling = sample.enabling;
  m.current_limited_cycles = sample.current_limited_cycles;
  m.commutation_found = sample.commutation_found;
  m.homed = sample.homed;
  m.homing = sample.homing;
  m.found_phase_rad = sample.found_phase_rad;
  m.axis_offset_m = sample.axis_offset_m;
  const CommandAuthorityStatus& c = sample.commands;
  m.control_client = c.control_client;
  m.control_lease_remaining_s = c.control_lease_remaining_s;
  m.commands_admitted = c.admitted;
  m.commands_refused_malformed = c.refused_malformed;
  m.commands_refused_other_axis = c.refused_other_axis;
  m.commands_refused_other_session = c.refused_other_session;
  m.commands_refused_no_client = c.refused_no_client;
  m.commands_refused_replayed = c.refused_replayed;
  m.commands_refused_stale = c.refused_stale;
  m.commands_refused_not_in_control = c.refused_not_in_control;
  m.commands_refused_by_daemon = c.refused_by_daemon;
  m.datagrams_dropped = c.datagrams_dropped;
  m.commands_refused_unauthenticated = c.refused_unauthenticated;
  return m;
}

clm_lcm::servo_event_t to_message(const ServoEventSample& sample) {
  clm_lcm::servo_event_t m;
  m.utime = stamped(sample.utime);
  m.cycle = sample.cycle;
  m.code = sample.code;
  m.severity = sample.severity;
  m.text = std::string(sample.text.view());
  return m;
}

clm_lcm::servo_command_ack_t to_message(const ServoCommandAck& ack, std::string_view axis, std::int64_t session) {
  clm_lcm::servo_command_ack_t m;
  m.utime = stamped(ack.utime);
  m.sequence = ack.sequence;
  m.axis = std::string(axis);
  m.session = session;
  m.client = ack.client;
  m.accepted = ack.accepted;
  m.text = std::string(ack.text.view());
  return m;
}

// ---- commands ------------------------------------------------------------------

namespace {

std::string check_finite(const char* field, double value) {
  if (std::isfinite(value)) return "";
  return std::string(field) + " is not a finite number";
}

std::string copy_path(const char* field, const std::string& text, PathText& out) {
  if (text.empty()) return std::string(field) + " is empty";
  if (text.find('\0') != std::string::npos) return std::string(field) + " contains a NUL character";
  if (!out.assign(text)) {
    return std::string(field) + " is " + std::to_string(text.size()) + " characters long, at most " +
           std::to_string(PathText::kMaxChars) + " fit";
  }
  return "";
}

}  // namespace

std::string to_command(const clm_lcm::servo_command_t& message, servo::Command& out) {
  servo::Command command;
  command.utime = message.utime;
  command.sequence = message.sequence;
  command.session = message.session;
  command.client = message.client;
  if (!command.axis.assign(message.axis)) return "axis is longer than 32 characters";
  if (!servo::is_command_kind(message.command)) {
    return "unknown command " + std::to_string(message.command) + " (1.." + std::to_string(servo::kCommandKinds) + ")";
  }
  command.kind = static_cast<CommandKind>(message.command);
  std::string reason;
  // The file a command names: the field its row of the command table says
  // (over LCM never empty, also for load_feedforward).
  switch (servo::route(command.kind).file) {
    case servo::FileUse::kNone: break;
    case servo::FileUse::kProgram: reason = copy_path("program", message.program, command.program); break;
    case servo::FileUse::kPath:
    case servo::FileUse::kPathOrValues: reason = copy_path("path", message.path, command.path); break;
  }
  switch (command.kind) {
    case CommandKind::kEnable:
    case CommandKind::kDisable:
    case CommandKind::kClearFault:
    case CommandKind::kStop:
    case CommandKind::kQuickStop:
    case CommandKind::kTakeControl:
    case CommandKind::kReleaseControl:
    case CommandKind::kRenewControl:
    case CommandKind::kHome:
    case CommandKind::kRunProgram:       // its file: above
    case CommandKind::kLoadCalibration:
    case CommandKind::kLoadModel:
    case CommandKind::kLoadFeedforward:
      break;
    case CommandKind::kMoveTo:
      for (const auto& [field, value] : {std::pair{"target_m", message.target_m},
                                         std::pair{"velocity_m_per_s", message.velocity_m_per_s},
                                         std::pair{"acceleration_m_per_s2", message.acceleration_m_per_s2},
                                         std::pair{"jerk_m_per_s3", message.jerk_m_per_s3}}) {
        if (reason.empty()) reason = check_finite(field, value);
      }
      command.target_m = message.target_m;
      command.limits = {message.velocity_m_per_s, message.acceleration_m_per_s2, message.jerk_m_per_s3};
      break;
    case CommandKind::kJog:
      for (const auto& [field, value] : {std::pair{"velocity_m_per_s", message.velocity_m_per_s},
                                         std::pair{"acceleration_m_per_s2", message.acceleration_m_per_s2},
                                         std::pair{"jerk_m_per_s3", message.jerk_m_per_s3}}) {
        if (reason.empty()) reason = check_finite(field, value);
      }
      command.jog_velocity_m_per_s = message.velocity_m_per_s;
      command.limits = {std::abs(message.velocity_m_per_s), message.acceleration_m_per_s2, message.jerk_m_per_s3};
      break;
    case CommandKind::kSetCommutation:
      if (message.commutation < servo_state_t::COMMUTATION_ORIGINAL ||
          message.commutation > servo_state_t::COMMUTATION_EXPERIMENT) {
        reason = "unknown commutation mode " + std::to_string(message.commutation) + " (0..5)";
      } else {
        command.commutation = static_cast<servo::CommutationMode>(message.commutation);
      }
      break;
    case CommandKind::kSetExperiment:
      if (message.coil_set < 1 || message.coil_set > kMaxCoilSets) {
        reason = "coil_set " + std::to_string(message.coil_set) + " outside 1.." + std::to_string(kMaxCoilSets);
      } else {
        reason = check_finite("delta_rad", message.delta_rad);
      }
      command.commutation = servo::CommutationMode::kExperiment;
      command.coil_set = message.coil_set;
      command.delta_rad = message.delta_rad;
      break;
    case CommandKind::kSetParameter:
      reason = check_finite("value", message.value);
      command.value = message.value;
      [[fallthrough]];
    case CommandKind::kGetParameter:
      if (reason.empty() && (message.parameter.empty() || !command.parameter.assign(message.parameter))) {
        reason = "parameter must have 1.." + std::to_string(decltype(command.parameter)::kMaxChars) + " characters";
      }
      break;
  }
  if (reason.empty()) out = command;
  return reason;
}

clm_lcm::servo_command_t to_message(const servo::Command& command) {
  clm_lcm::servo_command_t message{};
  message.utime = command.utime;
  message.sequence = command.sequence;
  message.axis = std::string(command.axis.view());
  message.session = command.session;
  message.client = command.client;
  message.command = static_cast<std::int8_t>(command.kind);
  switch (servo::route(command.kind).file) {
    case servo::FileUse::kNone: break;
    case servo::FileUse::kProgram: message.program = std::string(command.program.view()); break;
    case servo::FileUse::kPath:
    case servo::FileUse::kPathOrValues: message.path = std::string(command.path.view()); break;
  }
  switch (command.kind) {
    case CommandKind::kMoveTo:
      message.target_m = command.target_m;
      message.velocity_m_per_s = command.limits.velocity_m_per_s;
      message.acceleration_m_per_s2 = command.limits.acceleration_m_per_s2;
      message.jerk_m_per_s3 = command.limits.jerk_m_per_s3;
      break;
    case CommandKind::kJog:
      message.velocity_m_per_s = command.jog_velocity_m_per_s;
      message.acceleration_m_per_s2 = command.limits.acceleration_m_per_s2;
      message.jerk_m_per_s3 = command.limits.jerk_m_per_s3;
      break;
    case CommandKind::kSetCommutation: message.commutation = static_cast<std::int8_t>(command.commutation); break;
    case CommandKind::kSetExperiment:
      message.coil_set = static_cast<std::int8_t>(command.coil_set);
      message.delta_rad = command.delta_rad;
      break;
    case CommandKind::kSetParameter:
      message.value = command.value;
      [[fallthrough]];
    case CommandKind::kGetParameter: message.parameter = std::string(command.parameter.view()); break;
    default: break;  // no fields beyond the kind (a file: above)
  }
  return message;
}

}  // namespace clm::telemetry
