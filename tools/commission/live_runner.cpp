#include "tools/commission/live_runner.hpp"

#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>

#include "clm_lcm/servo_command_ack_t.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/telemetry/telemetry.hpp"

namespace clm::commission {
namespace {

using Command = clm_lcm::servo_command_t;
using clm_lcm::servo_state_t;
using clm_lcm::servo_status_t;

constexpr std::int8_t kStateEnabled = servo_status_t::STATE_ENABLED;
constexpr std::int8_t kStateFault = servo_status_t::STATE_FAULT;

/// Wall-clock µs × 1000 + a random 0..999, as `clm ctl` does: unlikely to
/// collide with another client's sequence.
std::int64_t fresh_sequence() {
  static std::mt19937_64 random{std::random_device{}()};
  return telemetry::wall_clock_utime() * 1000 + static_cast<std::int64_t>(random() % 1000);
}

Command make_command(std::int8_t kind) {
  Command command{};
  command.command = kind;
  return command;
}

std::string seconds(double value_s) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g s", value_s);
  return text;
}

template <typename Message>
bool decode(const std::vector<std::uint8_t>& data, Message& out) {
  const int size = static_cast<int>(data.size());
  return out.decode(data.data(), 0, size) == size;
}

}  // namespace

StateGaps find_state_gaps(const std::vector<std::int64_t>& cycles, int max_ranges) {
  StateGaps gaps;
  int listed = 0;
  for (std::size_t k = 1; k < cycles.size(); ++k) {
    const std::int64_t step = cycles[k] - cycles[k - 1];
    if (step <= 0) {
      ++gaps.out_of_order;
      continue;
    }
    if (step == 1) continue;
    gaps.missing += step - 1;
    if (listed < max_ranges) {
      if (!gaps.ranges.empty()) gaps.ranges += ", ";
      gaps.ranges += std::to_string(cycles[k - 1] + 1);
      if (step > 2) gaps.ranges += ".." + std::to_string(cycles[k] - 1);
    } else if (listed == max_ranges) {
      gaps.ranges += ", ...";
    }
    ++listed;
  }
  return gaps;
}

LcmRunner::LcmRunner(const servod::ServodConfig& config, LiveOptions options)
    : config_(config), options_(std::move(options)) {
  if (!(options_.ack_timeout_s > 0.0)) throw std::invalid_argument("live commissioning: the ack timeout must be positive");
  if (options_.attempts_per_run < 1) throw std::invalid_argument("live commissioning: attempts per run must be at least 1");
  // A large receive buffer: a burst of states after a stall must not overflow it.
  lcm_ = std::make_unique<lcm::LCM>(telemetry::with_receive_buffer(options_.lcm_url));
  if (!lcm_->good()) {
    throw std::runtime_error("cannot open LCM at '" + options_.lcm_url +
                             "' (for udpm a multicast route is needed: docs/telemetry.md)");
  }
  // Every channel: the daemon's states, status, events and acks, and the
  // commands themselves (multicast loops them back), all go into the logs.
  lcm::Subscription* subscription = lcm_->subscribe(".*", &LcmRunner::on_message, this);
  // LCM drops what a subscription has queued beyond its capacity, 30
  // messages by default: 30 ms of states. A receiving thread descheduled
  // longer on a loaded host lost bursts of 14 to 300 states that the daemon
  // had published and the kernel had delivered. A minute of states at 1 kHz.
  subscription->setQueueCapacity(60000);
  summary_.live = true;
  summary_.lcm_url = options_.lcm_url;
  receiver_ = std::thread([this] { receive_loop(); });
}

LcmRunner::~LcmRunner() {
  stop_.store(true);
  if (receiver_.joinable()) receiver_.join();
}

void LcmRunner::receive_loop() {
  while (!stop_.load()) lcm_->handleTimeout(50);
}

void LcmRunner::on_message(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  const auto* bytes = static_cast<const std::uint8_t*>(buffer->data);
  ReceivedMessage message{channel, buffer->recv_utime, std::vector<std::uint8_t>(bytes, bytes + buffer->data_size)};
  std::lock_guard lock(mutex_);
  if (channel == telemetry::kStateChannel) {
    servo_state_t state;
    if (decode(message.data, state)) {
      state_ = std::move(state);
      ++states_seen_;
    } else {
      ++undecodable_;
    }
  } else if (channel == telemetry::kStatusChannel) {
    servo_status_t status;
    if (decode(message.data, status)) {
      if (!first_dropped_) first_dropped_ = status.telemetry_dropped;
      status_ = std::move(status);
    } else {
      ++undecodable_;
    }
  } else if (channel == telemetry::kCommandAckChannel) {
    clm_lcm::servo_command_ack_t ack;
    if (decode(message.data, ack)) {
      acks_[ack.sequence] = Ack{static_cast<bool>(ack.accepted), ack.text};
    } else {
      ++undecodable_;
    }
  }
  if (capturing_) captured_.push_back(std::move(message));
  changed_.notify_all();
}

std::string LcmRunner::command(const std::string& what, Command message) {
  message.utime = telemetry::wall_clock_utime();
  message.sequence = fresh_sequence();
  if (lcm_->publish(telemetry::kCommandChannel, &message) != 0) {
    throw std::runtime_error("LCM refused to publish " + what + " on " + telemetry::kCommandChannel + " at " +
                             options_.lcm_url);
  }
  std::unique_lock lock(mutex_);
  const auto timeout = std::chrono::duration<double>(options_.ack_timeout_s);
  if (!changed_.wait_for(lock, timeout, [&] { return acks_.count(message.sequence) > 0; })) {
    throw std::runtime_error("no " + std::string(telemetry::kCommandAckChannel) + " for " + what + " (sequence " +
                             std::to_string(message.sequence) + ") within " + seconds(options_.ack_timeout_s) +
                             " on " + options_.lcm_url + " (is clm-servod running with that lcm_url?)");
  }
  const Ack ack = acks_[message.sequence];
  acks_.erase(message.sequence);
  if (!ack.accepted) throw std::runtime_error("clm-servod refused " + what + ": " + ack.text);
  return ack.text;
}

std::string LcmRunner::fault_text() const {
  if (status_ && status_->fault != 0) {
    return "fault " + std::to_string(status_->fault) + " (" + status_->fault_reason + ") at cycle " +
           std::to_string(status_->fault_cycle);
  }
  return "a fault (CLM_SERVO_STATE state 2; see clm ctl status)";
}

void LcmRunner::wait_for_state(const std::string& what, double timeout_s,
                               const std::function<bool(const servo_state_t&)>& done) {
  std::unique_lock lock(mutex_);
  const bool finished = changed_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
    return state_ && (state_->state == kStateFault || done(*state_));
  });
  if (finished && state_->state == kStateFault) {
    // The status may trail the state by up to one status period.
    changed_.wait_for(lock, std::chrono::milliseconds(300), [&] { return status_ && status_->fault != 0; });
    throw std::runtime_error("clm-servod latched " + fault_text() + " while waiting for " + what);
  }
  if (!finished) {
    std::string last = state_ ? "the last CLM_SERVO_STATE is of cycle " + std::to_string(state_->cycle)
                              : "no CLM_SERVO_STATE received on " + options_.lcm_url;
    if (undecodable_ > 0) {
      last += "; " + std::to_string(undecodable_) + " messages did not decode (a clm-servod built from other lcmtypes?)";
    }
    throw std::runtime_error(what + ": not within " + seconds(timeout_s) + " (" + last + ")");
  }
}

void LcmRunner::wait_cycles(std::int64_t cycles, const std::string& what) {
  std::int64_t target = 0;
  {
    std::lock_guard lock(mutex_);
    target = states_seen_ + cycles;
  }
  const double timeout_s = 2.0 + 2.0 * static_cast<double>(cycles) * config_.servo.period_s;
  std::unique_lock lock(mutex_);
  if (!changed_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return states_seen_ >= target; })) {
    throw std::runtime_error(what + ": " + std::to_string(cycles) + " CLM_SERVO_STATE messages did not come within " +
                             seconds(timeout_s) + " on " + options_.lcm_url);
  }
  if (state_ && state_->state == kStateFault) throw std::runtime_error("clm-servod latched " + fault_text() + " during " + what);
}

void LcmRunner::enable() {
  command("ENABLE", make_command(Command::ENABLE));
  wait_for_state("CLM_SERVO_STATE of the enabled axis", 2.0,
                 [](const servo_state_t& s) { return s.state == kStateEnabled; });
  // The daemon must be the one this configuration describes, publishing every cycle.
  std::vector<std::int64_t> cycles;
  std::vector<double> times_s;
  int coil_sets = 0;
  {
    std::lock_guard lock(mutex_);
    captured_.clear();
    capturing_ = true;
  }
  wait_cycles(50, "the check of the daemon's telemetry");
  std::vector<ReceivedMessage> messages;
  {
    std::lock_guard lock(mutex_);
    capturing_ = false;
    messages.swap(captured_);
  }
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
  for (std::size_t k = 1; k < cycles.size(); ++k) {
    if (cycles[k] - cycles[k - 1] != 1) continue;
    const double period_s = times_s[k] - times_s[k - 1];
    if (std::abs(period_s - config_.servo.period_s) > 1e-3 * config_.servo.period_s) {
      throw std::runtime_error("clm-servod runs at a period of " + seconds(period_s) + ", " + config_.origin +
                               " says " + seconds(config_.servo.period_s) + ": give --config the daemon's configuration");
    }
    break;
  }
}

void LcmRunner::set_experiment(int coil_set, double delta_rad) {
  Command message = make_command(Command::SET_EXPERIMENT);
  message.coil_set = static_cast<std::int8_t>(coil_set);
  message.delta_rad = delta_rad;
  char what[96];
  std::snprintf(what, sizeof(what), "SET_EXPERIMENT (coil set %d, delta_rad %.6f)", coil_set, delta_rad);
  command(what, message);
  wait_for_state(std::string("experiment mode after ") + what, 5.0, [&](const servo_state_t& s) {
    return s.commutation == servo_state_t::COMMUTATION_EXPERIMENT && s.coil_set == coil_set && s.delta_rad == delta_rad;
  });
}

void LcmRunner::set_commutation(servo::CommutationMode mode) {
  Command message = make_command(Command::SET_COMMUTATION);
  message.commutation = static_cast<std::int8_t>(mode);
  const std::string what = std::string("SET_COMMUTATION ") + servo::name(mode);
  command(what, message);
  wait_for_state(std::string("commutation ") + servo::name(mode) + " in use", 5.0,
                 [&](const servo_state_t& s) { return s.commutation == static_cast<std::int8_t>(mode); });
}

void LcmRunner::load_calibration(const std::string& path) {
  Command message = make_command(Command::LOAD_CALIBRATION);
  message.path = path;
  command("LOAD_CALIBRATION " + path, message);
  // Swapped in at the next standstill: the axis stands still, so within a cycle.
  wait_cycles(20, "LOAD_CALIBRATION " + path);
}

void LcmRunner::load_model(servo::CommutationMode, const std::string& path) {
  // The daemon takes the law from the file's own kind:.
  Command message = make_command(Command::LOAD_MODEL);
  message.path = path;
  command("LOAD_MODEL " + path, message);
  wait_cycles(20, "LOAD_MODEL " + path);
}

void LcmRunner::load_feedforward(const control::FeedforwardParameters&, const std::string& path) {
  Command message = make_command(Command::LOAD_FEEDFORWARD);
  message.path = path;
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
  {
    std::lock_guard lock(mutex_);
    if (state_) hold_m = state_->r_m;
  }
  const auto& limits = program.steps.front().limits;
  Command move = make_command(Command::MOVE_TO);
  move.target_m = program.start_m;
  move.velocity_m_per_s = limits.velocity_m_per_s;
  move.acceleration_m_per_s2 = limits.acceleration_m_per_s2;
  move.jerk_m_per_s3 = limits.jerk_m_per_s3;
  const double move_s = control::MoveProgram(hold_m, {{program.start_m, limits, 0.0}}).duration_s();
  command("MOVE_TO " + std::to_string(program.start_m) + " m (start of '" + name + "')", move);
  wait_for_state("the move to the start of '" + name + "'", move_s + 10.0, [&](const servo_state_t& s) {
    return !s.program_running && std::abs(s.r_m - program.start_m) < 1e-9 && std::abs(s.r_dot_m_per_s) < 1e-12 &&
           s.state == kStateEnabled;
  });
  wait_cycles(200, "settling before '" + name + "'");

  {
    std::lock_guard lock(mutex_);
    captured_.clear();
    capturing_ = true;
  }
  const double program_s = control::MoveProgram(program.start_m, program.steps).duration_s();
  Command run = make_command(Command::RUN_PROGRAM);
  run.program = program_path;
  command("RUN_PROGRAM " + program_path + " ('" + name + "')", run);
  wait_for_state("the start of '" + name + "'", 5.0, [](const servo_state_t& s) { return s.program_running; });
  wait_for_state("the end of '" + name + "'", program_s + 10.0, [](const servo_state_t& s) { return !s.program_running; });
  wait_cycles(20, "the end of '" + name + "'");  // the status and events that trail the last cycle
  {
    std::lock_guard lock(mutex_);
    capturing_ = false;
    messages.swap(captured_);
    captured_.clear();
  }

  Recording recording{name, {}, {}, 0, 0};  // no simulator truth over LCM
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
    if (s.damping_engaged) ++recording.damping_cycles;
    if (s.force_limited) ++recording.force_limited_cycles;
  }
  gaps = find_state_gaps(cycles);
  if (recording.samples.empty()) throw std::runtime_error("run '" + name + "': no CLM_SERVO_STATE of the running program");
  return recording;
}

Recording LcmRunner::run_program(const servod::ProgramFile& program, const std::string& program_path,
                                 const std::string& name) {
  ++summary_.runs;
  for (int k = 1;; ++k) {
    std::vector<ReceivedMessage> messages;
    StateGaps gaps;
    std::int64_t states = 0;
    Recording recording = attempt(program, program_path, name, messages, gaps, states);
    summary_.states_received += states;
    if (gaps.missing == 0 && gaps.out_of_order == 0) {
      summary_.states_recorded += static_cast<std::int64_t>(recording.samples.size());
      if (log_) {
        // The program's states, and every other message of the run.
        for (const auto& message : messages) {
          if (message.channel == telemetry::kStateChannel) {
            servo_state_t s;
            if (!decode(message.data, s) || !s.program_running || s.state != kStateEnabled) continue;
          }
          log_->publish(message.channel, message.data, message.utime);
        }
      }
      return recording;
    }
    const std::string problem = std::to_string(gaps.missing) + " CLM_SERVO_STATE messages missing" +
                                (gaps.ranges.empty() ? "" : " (cycles " + gaps.ranges + ")") +
                                (gaps.out_of_order > 0 ? ", " + std::to_string(gaps.out_of_order) + " out of order" : "");
    summary_.states_missing_discarded += gaps.missing;
    if (k >= options_.attempts_per_run) {
      throw std::runtime_error("run '" + name + "': " + problem + " in attempt " + std::to_string(k) + " of " +
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
  std::lock_guard lock(mutex_);
  if (first_dropped_ && status_) summary.daemon_telemetry_dropped = status_->telemetry_dropped - *first_dropped_;
  return summary;
}

std::vector<std::string> LcmRunner::notes() const { return notes_; }

}  // namespace clm::commission
