#include "tools/commission/live_runner.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <stdexcept>

#include "config/exit_status.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/telemetry/telemetry.hpp"
#include "tools/lcmlog/servo_log.hpp"
#include "tools/servod_client/config_update.hpp"

namespace clm::commission {
namespace {

using Command = servo::Command;
using Kind = servo::CommandKind;
using clm_lcm::servo_state_t;
using clm_lcm::servo_status_t;
using servod_client::decode;
using servod_client::make_command;
using servod_client::seconds;

constexpr std::int8_t kStateEnabled = servo_status_t::STATE_ENABLED;
constexpr std::int8_t kStateDisabled = servo_status_t::STATE_DISABLED;

/// `options`, or std::invalid_argument naming the one out of range.
LiveOptions checked(LiveOptions options) {
  if (!(options.ack_timeout_s > 0.0)) throw std::invalid_argument("live commissioning: the ack timeout must be positive");
  if (options.attempts_per_run < 1) throw std::invalid_argument("live commissioning: attempts per run must be at least 1");
  return options;
}

/// Every channel: the daemon's states, status, events and acks, and the
/// commands themselves (multicast loops them back), all go into the logs;
/// every state of a run must arrive.
servod_client::Options client_options(const LiveOptions& options) {
  servod_client::Options client;
  client.lcm_url = options.lcm_url;
  client.key_file = options.key_file;
  client.channels = ".*";
  client.every_state = true;
  // An identity of its own: `clm ctl` of the same user is another client, so
  // their leases never mix (docs/servod.md, "The deadman").
  client.client_id = servod_client::commission_client_id();
  return client;
}

}  // namespace

StateGaps find_state_gaps(const std::vector<std::int64_t>& cycles, int max_ranges) {
  const lcmlog::CycleGaps found = lcmlog::find_cycle_gaps(cycles, 1, {}, max_ranges);
  StateGaps gaps;
  gaps.missing = found.missing;
  gaps.out_of_order = found.out_of_order;
  gaps.ranges = lcmlog::describe_ranges(found);
  return gaps;
}

LcmRunner::LcmRunner(const servod::ServodConfig& config, LiveOptions options)
    : config_(config), options_(checked(std::move(options))), client_(client_options(options_)) {
  summary_.live = true;
  summary_.lcm_url = options_.lcm_url;
}

LcmRunner::~LcmRunner() {
  // Control goes back at the end, also when commissioning failed or a signal
  // ended it: the renewals stop, whatever runs is stopped, and releasing the
  // deadman lease has the daemon end an experiment (the service law at
  // standstill). Should any of this not get through, the deadman does it.
  if (!took_control_) return;
  client_.stop_deadman();
  try {
    client_.stop_and_release(options_.ack_timeout_s);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "clm commission: warning: control of the axis not released (the daemon's deadman "
                         "stops the axis and releases it): %s\n", e.what());
  }
}

std::string LcmRunner::command(const std::string& what, Command message) {
  return client_.command(what, std::move(message), options_.ack_timeout_s);
}

void LcmRunner::wait_cycles(std::int64_t cycles, const std::string& what) {
  const double timeout_s = 2.0 + 2.0 * static_cast<double>(cycles) * config_.servo.period_s;
  client_.wait_states(cycles, timeout_s, what);
}

DaemonView LcmRunner::observe() {
  client_.target_for(options_.ack_timeout_s, "ENABLE");
  DaemonView view;
  view.status = client_.wait_for_status(options_.ack_timeout_s);
  for (int k = 0; k < 10 && !client_.latest_state(); ++k) {
    try {
      client_.wait_states(1, 0.1, "a CLM_SERVO_STATE for the checks before the first experiment");
    } catch (const servod_client::Timeout&) {
      // Telemetry of states may lag the status: try again.
    } catch (const servod_client::Faulted&) {
      break;  // a latched fault: the state still says the profile
    }
  }
  view.state = client_.latest_state();
  return view;
}

void LcmRunner::enable() {
  // The first command of commissioning: take control for all of it.
  client_.take_control(options_.ack_timeout_s, "ENABLE");
  took_control_ = true;
  client_.start_deadman();
  // A configuration with a force sensor measures forces: a daemon without a
  // working sensor is refused before the axis is enabled (control, taken
  // above from a status of the axis, is given back by the destructor). One
  // without (commissioning from positions) runs on the encoder alone.
  const auto status = client_.latest_status();
  // The configuration must be the daemon's (axis and motor), before anything
  // moves: what commissioning measures and --save writes is for that motor.
  if (status) servod_client::require_daemons_configuration(config_, *status);
  if (status && !can::has_force_sensor(config_.servo.protocol)) {
    if (status->force_sensor != servo_status_t::FORCE_SENSOR_NONE) {
      throw RunTimeFailure("clm-servod's axis '" + status->axis + "' has a force sensor, which this configuration "
                           "does not name (can.force_sensor_node_id): the daemon runs another configuration");
    }
  } else if (status) {
    if (status->force_sensor == servo_status_t::FORCE_SENSOR_NONE) {
      throw RunTimeFailure("clm-servod's axis '" + status->axis + "' has no force sensor (can.force_sensor_node_id "
                               "absent in its configuration); commissioning measures forces");
    }
    if (status->force_sensor == servo_status_t::FORCE_SENSOR_LOST) {
      throw RunTimeFailure("clm-servod's axis '" + status->axis + "' has lost its force sensor (warning " +
                               std::to_string(status->force_sensor_warning) + "); commissioning measures forces");
    }
  }
  enable_axis();
  // The daemon must be the one this configuration describes, publishing every cycle.
  std::vector<std::int64_t> cycles;
  std::vector<double> times_s;
  int coil_sets = 0;
  client_.start_capture();
  wait_cycles(50, "the check of the daemon's telemetry");
  const std::vector<ReceivedMessage> messages = client_.stop_capture();
  for (const auto& message : messages) {
    servo_state_t state;
    if (message.channel != telemetry::kStateChannel || !decode(message.data, state)) continue;
    cycles.push_back(state.cycle);
    times_s.push_back(state.t_s);
    coil_sets = state.coil_sets;
  }
  if (coil_sets != config_.motor.coil_sets) {
    throw std::runtime_error("clm-servod drives " + std::to_string(coil_sets) + " coil sets, " + config_.origin +
                             " describes a motor with " + std::to_string(config_.motor.coil_sets) +
                             ": give --config the daemon's configuration");
  }
  std::int64_t smallest_step = std::numeric_limits<std::int64_t>::max();
  for (std::size_t k = 1; k < cycles.size(); ++k) smallest_step = std::min(smallest_step, cycles[k] - cycles[k - 1]);
  if (smallest_step > 1 && smallest_step != std::numeric_limits<std::int64_t>::max()) {
    throw std::runtime_error("clm-servod publishes every " + std::to_string(smallest_step) +
                             "th cycle's CLM_SERVO_STATE; commissioning records every cycle: set "
                             "telemetry.state_decimation: 1 in the daemon's configuration");
  }
  // The period: the median step of t_s between consecutive cycles, so that a
  // late wake-up of a loaded host (one step of several periods) is not taken
  // for another rate.
  std::vector<double> steps_s;
  for (std::size_t k = 1; k < cycles.size(); ++k) {
    if (cycles[k] - cycles[k - 1] == 1) steps_s.push_back(times_s[k] - times_s[k - 1]);
  }
  if (!steps_s.empty()) {
    std::nth_element(steps_s.begin(), steps_s.begin() + static_cast<std::ptrdiff_t>(steps_s.size() / 2), steps_s.end());
    const double period_s = steps_s[steps_s.size() / 2];
    if (std::abs(period_s - config_.servo.period_s) > 1e-3 * config_.servo.period_s) {
      throw std::runtime_error("clm-servod runs at a period of " + seconds(period_s) + ", " + config_.origin +
                               " says " + seconds(config_.servo.period_s) + ": give --config the daemon's configuration");
    }
  }
}

void LcmRunner::set_experiment(int coil_set, double delta_rad) {
  Command message = make_command(Kind::kSetExperiment);
  message.coil_set = coil_set;
  message.delta_rad = delta_rad;
  char what[96];
  std::snprintf(what, sizeof(what), "SET_EXPERIMENT (coil set %d, delta_rad %.6f)", coil_set, delta_rad);
  command(what, message);
  client_.wait_for_state(std::string("experiment mode after ") + what, 5.0, [&](const servo_state_t& s) {
    return s.commutation == servo_state_t::COMMUTATION_EXPERIMENT && s.coil_set == coil_set && s.delta_rad == delta_rad;
  });
}

void LcmRunner::set_payload(double payload_kg) {
  // The operator reaches into the machine: the axis is disabled first, and
  // enabled again only after the confirmation.
  command("DISABLE", make_command(Kind::kDisable));
  client_.wait_for_state("CLM_SERVO_STATE of the disabled axis", 5.0,
                         [](const servo_state_t& s) { return s.state == kStateDisabled; });
  if (payload_kg > 0.0) {
    std::fprintf(stderr,
                 "commission: the axis is disabled. Mount the payload of %.6g kg on the translator, fixed as a tool "
                 "would be (the experiments move it), then press Enter; end of input aborts.\n",
                 payload_kg);
  } else {
    std::fprintf(stderr, "commission: the axis is disabled. Remove the payload, then press Enter; end of input "
                         "aborts.\n");
  }
  std::string line;
  if (!std::getline(std::cin, line)) {
    throw RunTimeFailure("the payload experiments need an operator: no confirmation on stdin (end of input)");
  }
  enable_axis();
}

void LcmRunner::enable_axis() {
  const auto status = client_.latest_status();
  if (config_.servo.homing.incremental() && (!status || !status->homed)) {
    // An axis at its power-up offset: home enables, finds the commutation
    // and the reference (docs/servod.md, "Homing"), within the time its
    // search may take and the finding's.
    command("HOME", make_command(Kind::kHome));
    const auto& homing = config_.servo.homing;
    const double timeout_s = homing.search_distance_m / homing.search_velocity_m_per_s + 30.0;
    const auto start = std::chrono::steady_clock::now();
    for (;;) {
      const servo_status_t now = client_.wait_for_status(timeout_s);
      if (now.state == servo_status_t::STATE_FAULT) {
        throw RunTimeFailure("homing ended in fault " + std::to_string(now.fault) + ": " + now.fault_reason);
      }
      if (now.homed && now.homing == servo_status_t::HOMING_IDLE && now.state == servo_status_t::STATE_ENABLED) break;
      if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > timeout_s) {
        throw RunTimeFailure("the axis was not homed within " + std::to_string(timeout_s) + " s of HOME");
      }
    }
  }
  command("ENABLE", make_command(Kind::kEnable));
  client_.wait_for_state("CLM_SERVO_STATE of the enabled axis", 2.0,
                         [](const servo_state_t& s) { return s.state == kStateEnabled; });
}

void LcmRunner::set_commutation(servo::CommutationMode mode) {
  Command message = make_command(Kind::kSetCommutation);
  message.commutation = mode;
  const std::string what = std::string("SET_COMMUTATION ") + servo::name(mode);
  command(what, message);
  client_.wait_for_state(std::string("commutation ") + servo::name(mode) + " in use", 5.0,
                 [&](const servo_state_t& s) { return s.commutation == static_cast<std::int8_t>(mode); });
}

void LcmRunner::load_calibration(const std::string& path) {
  Command message = make_command(Kind::kLoadCalibration);
  servod_client::assign_text(message.path, path, "calibration file");
  try {
    command("LOAD_CALIBRATION " + path, message);
  } catch (const servod_client::Refused& refused) {
    throw LawRefused(refused.what());
  }
  // Swapped in at the next standstill: the axis stands still, so within a cycle.
  wait_cycles(20, "LOAD_CALIBRATION " + path);
}

void LcmRunner::load_model(servo::CommutationMode, const std::string& path) {
  // The daemon takes the law from the file's own kind:.
  Command message = make_command(Kind::kLoadModel);
  servod_client::assign_text(message.path, path, "model file");
  try {
    command("LOAD_MODEL " + path, message);
  } catch (const servod_client::Refused& refused) {
    throw LawRefused(refused.what());
  }
  wait_cycles(20, "LOAD_MODEL " + path);
}

void LcmRunner::load_feedforward(const control::FeedforwardParameters&, const std::string& path) {
  Command message = make_command(Kind::kLoadFeedforward);
  servod_client::assign_text(message.path, path, "feedforward file");
  command("LOAD_FEEDFORWARD " + path, message);  // acked once the cycle has taken the parameters
}

void LcmRunner::open_log(const std::string& path) {
  close_log();
  log_ = std::make_unique<telemetry::LcmLogWriter>(path);
}

void LcmRunner::close_log() {
  if (log_) log_->close();
  log_.reset();
}

Recording LcmRunner::attempt(const servod::ProgramFile& program, const std::string& program_path,
                             const std::string& name, std::vector<ReceivedMessage>& messages, StateGaps& gaps,
                             std::int64_t& states) {
  // Approach: move to the start and settle, as the in-process runner does.
  double hold_m = 0.0;
  if (const auto state = client_.latest_state()) hold_m = state->r_m;
  const auto& limits = program.steps.front().limits;
  Command move = make_command(Kind::kMoveTo);
  move.target_m = program.start_m;
  move.limits = limits;
  const double move_s = control::MoveProgram(hold_m, {{program.start_m, limits, 0.0}}).duration_s();
  command("MOVE_TO " + std::to_string(program.start_m) + " m (start of '" + name + "')", move);
  client_.wait_for_state("the move to the start of '" + name + "'", move_s + 10.0, [&](const servo_state_t& s) {
    return !s.program_running && std::abs(s.r_m - program.start_m) < 1e-9 && std::abs(s.r_dot_m_per_s) < 1e-12 &&
           s.state == kStateEnabled;
  });
  wait_cycles(200, "settling before '" + name + "'");

  client_.start_capture();
  const double program_s = control::MoveProgram(program.start_m, program.steps).duration_s();
  Command run = make_command(Kind::kRunProgram);
  servod_client::assign_text(run.program, program_path, "program file");
  command("RUN_PROGRAM " + program_path + " ('" + name + "')", run);
  client_.wait_for_state("the start of '" + name + "'", 5.0, [](const servo_state_t& s) { return s.program_running; });
  client_.wait_for_state("the end of '" + name + "'", program_s + 10.0, [](const servo_state_t& s) { return !s.program_running; });
  wait_cycles(20, "the end of '" + name + "'");  // the status and events that trail the last cycle
  messages = client_.stop_capture();

  Recording recording;  // no simulator truth over LCM
  recording.name = name;
  std::vector<std::int64_t> cycles;
  states = 0;
  for (const auto& message : messages) {
    servo_state_t s;
    if (message.channel != telemetry::kStateChannel || !decode(message.data, s)) continue;
    ++states;
    cycles.push_back(s.cycle);
    if (!s.program_running || s.state != kStateEnabled) continue;
    try {
      recording.samples.push_back(telemetry::to_record(s));
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error("run '" + name + "': CLM_SERVO_STATE of cycle " + std::to_string(s.cycle) + ": " + e.what());
    }
    if (!s.force_measured && can::has_force_sensor(config_.servo.protocol)) ++gaps.force_unmeasured;
    if (s.damping_engaged) ++recording.damping_cycles;
    if (s.force_limited) ++recording.force_limited_cycles;
  }
  const std::int64_t force_unmeasured = gaps.force_unmeasured;
  gaps = find_state_gaps(cycles);
  gaps.force_unmeasured = force_unmeasured;
  if (recording.samples.empty()) throw RunTimeFailure("run '" + name + "': no CLM_SERVO_STATE of the running program");
  return recording;
}

Recording LcmRunner::run_program(const servod::ProgramFile& program, const std::string& program_path,
                                 const std::string& name, Disturbance) {
  ++summary_.runs;
  for (int k = 1;; ++k) {
    std::vector<ReceivedMessage> messages;
    StateGaps gaps;
    std::int64_t states = 0;
    Recording recording = attempt(program, program_path, name, messages, gaps, states);
    summary_.states_received += states;
    if (gaps.missing == 0 && gaps.out_of_order == 0 && gaps.force_unmeasured == 0) {
      summary_.states_recorded += static_cast<std::int64_t>(recording.samples.size());
      if (log_) {
        // The program's states, and every other message of the run. The log
        // holds the runs only: the first state of each follows a marker.
        bool marked = false;
        for (const auto& message : messages) {
          if (message.channel == telemetry::kStateChannel) {
            servo_state_t s;
            if (!decode(message.data, s) || !s.program_running || s.state != kStateEnabled) continue;
            if (!marked) telemetry::mark_recording_resumed(*log_, s.cycle - 1, message.utime);
            marked = true;
          }
          log_->publish(message.channel, message.data, message.utime);
        }
      }
      return recording;
    }
    const std::string problem = std::to_string(gaps.missing) + " CLM_SERVO_STATE messages missing" +
                                (gaps.ranges.empty() ? "" : " (cycles " + gaps.ranges + ")") +
                                (gaps.out_of_order > 0 ? ", " + std::to_string(gaps.out_of_order) + " out of order" : "") +
                                (gaps.force_unmeasured > 0 ? ", " + std::to_string(gaps.force_unmeasured) +
                                                                 " without a force measurement"
                                                           : "");
    summary_.states_missing_discarded += gaps.missing;
    if (k >= options_.attempts_per_run) {
      throw RunTimeFailure("run '" + name + "': " + problem + " in attempt " + std::to_string(k) + " of " +
                               std::to_string(options_.attempts_per_run) +
                               "; no attempt was complete (a loaded host or a lossy network between clm and clm-servod)");
    }
    ++summary_.runs_repeated;
    notes_.push_back("live run '" + name + "' repeated: attempt " + std::to_string(k) + " had " + problem);
  }
}

std::string LcmRunner::oracle_unavailable_reason() const {
  return "live commissioning: the oracle (the simulator's true electromagnetics) exists only in the in-process simulation";
}

LiveSummary LcmRunner::live_summary() const {
  LiveSummary summary = summary_;
  const auto first = client_.first_status();
  const auto latest = client_.latest_status();
  if (first && latest) summary.daemon_telemetry_dropped = latest->telemetry_dropped - first->telemetry_dropped;
  return summary;
}

std::vector<std::string> LcmRunner::notes() const { return notes_; }

}  // namespace clm::commission
