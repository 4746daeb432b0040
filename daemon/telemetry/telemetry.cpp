#include "daemon/telemetry/telemetry.hpp"

#include <lcm/lcm-cpp.hpp>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "config/yaml_reader.hpp"

namespace clm::telemetry {

using clm_lcm::servo_command_t;
using clm_lcm::servo_state_t;

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

std::string with_receive_buffer(const std::string& url) {
  if (url.rfind("udpm://", 0) != 0 || url.find("recv_buf_size=") != std::string::npos) return url;
  return url + (url.find('?') == std::string::npos ? "?" : "&") + "recv_buf_size=4194304";
}

std::int64_t wall_clock_utime() noexcept {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

namespace {

std::int64_t stamp(std::int64_t utime) { return utime != 0 ? utime : wall_clock_utime(); }

}  // namespace

// ---- conversions -------------------------------------------------------------

clm_lcm::servo_state_t to_message(const ServoStateSample& sample) {
  if (sample.coil_sets < 0 || sample.coil_sets > kMaxCoilSets) {
    // A bug in the caller, not a measurement: refuse rather than cut the arrays.
    throw std::logic_error("ServoStateSample of cycle " + std::to_string(sample.cycle) + ": coil_sets " +
                           std::to_string(sample.coil_sets) + " outside 0.." + std::to_string(kMaxCoilSets));
  }
  servo_state_t m;
  m.utime = stamp(sample.utime);
  m.cycle = sample.cycle;
  m.t_s = sample.t_s;
  m.r_m = sample.r_m;
  m.r_dot_m_per_s = sample.r_dot_m_per_s;
  m.r_ddot_m_per_s2 = sample.r_ddot_m_per_s2;
  m.y_m = sample.y_m;
  m.e_m = sample.e_m;
  m.F_star_N = sample.F_star_N;
  m.u_fb_N = sample.u_fb_N;
  m.u_ff_N = sample.u_ff_N;
  m.Fy_star_N = sample.Fy_star_N;
  m.Fx_star_N = sample.Fx_star_N;
  m.Tz_star_Nm = sample.Tz_star_Nm;
  m.Fy_N = sample.Fy_N;
  m.Fx_N = sample.Fx_N;
  m.Tz_Nm = sample.Tz_Nm;
  m.commutation = sample.commutation;
  m.coil_set = sample.coil_set;
  m.delta_rad = sample.delta_rad;
  m.coil_sets = sample.coil_sets;
  const auto count = static_cast<std::size_t>(sample.coil_sets);
  m.magnitude_N.assign(sample.magnitude_N.begin(), sample.magnitude_N.begin() + count);
  m.setpoint_delta_rad.assign(sample.setpoint_delta_rad.begin(), sample.setpoint_delta_rad.begin() + count);
  m.ia_A.assign(sample.ia_A.begin(), sample.ia_A.begin() + count);
  m.ib_A.assign(sample.ib_A.begin(), sample.ib_A.begin() + count);
  m.damping_engaged = sample.damping_engaged;
  m.current_square_sum_A2 = sample.current_square_sum_A2;
  m.force_limited = sample.force_limited;
  m.state = sample.state;
  m.program_running = sample.program_running;
  m.program_time_s = sample.program_time_s;
  return m;
}

clm_lcm::servo_status_t to_message(const ServoStatusSample& sample, std::int64_t telemetry_dropped) {
  clm_lcm::servo_status_t m;
  m.utime = stamp(sample.utime);
  m.state = sample.state;
  m.fault = sample.fault;
  m.fault_reason = std::string(sample.fault_reason.view());
  m.fault_cycle = sample.fault_cycle;
  m.commutation = sample.commutation;
  m.model_file = std::string(sample.model_file.view());
  m.calibration_file = std::string(sample.calibration_file.view());
  m.wakeup_latency_p50_s = sample.wakeup_latency_p50_s;
  m.wakeup_latency_p99_s = sample.wakeup_latency_p99_s;
  m.wakeup_latency_max_s = sample.wakeup_latency_max_s;
  m.compute_time_p50_s = sample.compute_time_p50_s;
  m.compute_time_p99_s = sample.compute_time_p99_s;
  m.compute_time_max_s = sample.compute_time_max_s;
  m.overruns = sample.overruns;
  m.cycles = sample.cycles;
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
  return m;
}

clm_lcm::servo_event_t to_message(const ServoEventSample& sample) {
  clm_lcm::servo_event_t m;
  m.utime = stamp(sample.utime);
  m.cycle = sample.cycle;
  m.code = sample.code;
  m.severity = sample.severity;
  m.text = std::string(sample.text.view());
  return m;
}

clm_lcm::servo_command_ack_t to_message(const ServoCommandAck& ack) {
  clm_lcm::servo_command_ack_t m;
  m.utime = stamp(ack.utime);
  m.sequence = ack.sequence;
  m.accepted = ack.accepted;
  m.text = std::string(ack.text.view());
  return m;
}

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

std::string to_command(const clm_lcm::servo_command_t& message, ServoCommand& out) {
  ServoCommand command;
  command.utime = message.utime;
  command.sequence = message.sequence;
  if (message.command < servo_command_t::ENABLE || message.command > servo_command_t::LOAD_FEEDFORWARD) {
    return "unknown command " + std::to_string(message.command) + " (1..11)";
  }
  command.command = static_cast<CommandKind>(message.command);
  std::string reason;
  switch (command.command) {
    case CommandKind::kEnable:
    case CommandKind::kDisable:
    case CommandKind::kClearFault:
    case CommandKind::kStop:
      break;
    case CommandKind::kMoveTo:
      for (const auto& [field, value] : {std::pair{"target_m", message.target_m},
                                         std::pair{"velocity_m_per_s", message.velocity_m_per_s},
                                         std::pair{"acceleration_m_per_s2", message.acceleration_m_per_s2},
                                         std::pair{"jerk_m_per_s3", message.jerk_m_per_s3}}) {
        if (reason.empty()) reason = check_finite(field, value);
      }
      command.target_m = message.target_m;
      command.velocity_m_per_s = message.velocity_m_per_s;
      command.acceleration_m_per_s2 = message.acceleration_m_per_s2;
      command.jerk_m_per_s3 = message.jerk_m_per_s3;
      break;
    case CommandKind::kRunProgram:
      reason = copy_path("program", message.program, command.program);
      break;
    case CommandKind::kSetCommutation:
      if (message.commutation < servo_state_t::COMMUTATION_ORIGINAL ||
          message.commutation > servo_state_t::COMMUTATION_EXPERIMENT) {
        reason = "unknown commutation mode " + std::to_string(message.commutation) + " (0..5)";
      }
      command.commutation = message.commutation;
      break;
    case CommandKind::kSetExperiment:
      if (message.coil_set < 1 || message.coil_set > kMaxCoilSets) {
        reason = "coil_set " + std::to_string(message.coil_set) + " outside 1.." + std::to_string(kMaxCoilSets);
      } else {
        reason = check_finite("delta_rad", message.delta_rad);
      }
      command.commutation = servo_state_t::COMMUTATION_EXPERIMENT;
      command.coil_set = message.coil_set;
      command.delta_rad = message.delta_rad;
      break;
    case CommandKind::kLoadCalibration:
    case CommandKind::kLoadModel:
    case CommandKind::kLoadFeedforward:
      reason = copy_path("path", message.path, command.path);
      break;
  }
  if (reason.empty()) out = command;
  return reason;
}

// ---- sinks -------------------------------------------------------------------

void LcmSink::publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t /*utime*/) {
  const std::string name(channel);
  if (lcm_.publish(name, data.data(), static_cast<unsigned int>(data.size())) != 0) {
    throw std::runtime_error("LCM: cannot publish " + std::to_string(data.size()) + " bytes on " + name);
  }
}

LcmLogWriter::LcmLogWriter(std::string path) : path_(std::move(path)), temporary_path_(path_ + ".tmp") {
  errno = 0;
  log_ = std::make_unique<lcm::LogFile>(temporary_path_, "w");
  if (!log_->good()) {
    const int error = errno;
    throw std::runtime_error(temporary_path_ + ": cannot open for writing" +
                             (error != 0 ? std::string(": ") + std::strerror(error) : std::string()));
  }
}

LcmLogWriter::~LcmLogWriter() = default;

void LcmLogWriter::publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) {
  if (closed_) throw std::logic_error(path_ + ": log already closed");
  if (!error_.empty()) throw std::runtime_error(error_);
  lcm::LogEvent event{};
  event.timestamp = stamp(utime);
  event.channel = std::string(channel);
  event.datalen = static_cast<std::int32_t>(data.size());
  event.data = const_cast<std::uint8_t*>(data.data());  // LogEvent is shared with reading; writing does not modify
  if (log_->writeEvent(&event) != 0) {
    error_ = temporary_path_ + ": event " + std::to_string(events_written_) + ": write failed: " + std::strerror(errno);
    throw std::runtime_error(error_);
  }
  ++events_written_;
}

void LcmLogWriter::close() {
  if (closed_) return;
  if (!error_.empty()) throw std::runtime_error(error_ + "; the partial log stays at " + temporary_path_);
  FILE* file = log_->getFilePtr();
  if (std::fflush(file) != 0 || ::fsync(::fileno(file)) != 0) {
    error_ = temporary_path_ + ": cannot flush: " + std::strerror(errno);
    throw std::runtime_error(error_);
  }
  log_.reset();  // fclose
  if (std::rename(temporary_path_.c_str(), path_.c_str()) != 0) {
    error_ = path_ + ": cannot rename " + temporary_path_ + " into place: " + std::strerror(errno);
    throw std::runtime_error(error_);
  }
  closed_ = true;
}

void MemorySink::publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) {
  Event event{std::string(channel), stamp(utime), std::vector<std::uint8_t>(data.begin(), data.end())};
  const std::lock_guard lock(mutex_);
  events_.push_back(std::move(event));
}

std::vector<MemorySink::Event> MemorySink::events() const {
  const std::lock_guard lock(mutex_);
  return events_;
}

std::size_t MemorySink::size() const {
  const std::lock_guard lock(mutex_);
  return events_.size();
}

// ---- configuration -----------------------------------------------------------

namespace {

bool is_power_of_two(std::size_t n) { return n != 0 && (n & (n - 1)) == 0; }

const TelemetryConfig& validated(const TelemetryConfig& config) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("telemetry: " + what); };
  if (config.lcm_url.empty()) fail("lcm_url is empty");
  if (config.state_decimation < 1) fail("state_decimation " + std::to_string(config.state_decimation) + " < 1");
  for (const auto& [name, capacity] :
       {std::pair{"state_queue_capacity", config.state_queue_capacity},
        std::pair{"status_queue_capacity", config.status_queue_capacity},
        std::pair{"event_queue_capacity", config.event_queue_capacity},
        std::pair{"command_queue_capacity", config.command_queue_capacity},
        std::pair{"ack_queue_capacity", config.ack_queue_capacity}}) {
    if (!is_power_of_two(capacity)) fail(std::string(name) + " " + std::to_string(capacity) + " is not a power of two");
  }
  if (!(config.idle_period_s > 0.0 && config.idle_period_s <= 1.0)) {
    fail("idle_period_s " + std::to_string(config.idle_period_s) + " outside (0, 1] s");
  }
  return config;
}

}  // namespace

TelemetryConfig read_telemetry_config(const yaml::Node& section) {
  section.expect_map();
  section.expect_keys({"lcm_url", "state_decimation", "state_queue_capacity", "status_queue_capacity",
                       "event_queue_capacity", "command_queue_capacity", "ack_queue_capacity", "idle_period_s"});
  TelemetryConfig config;
  if (auto node = section.optional("lcm_url")) {
    config.lcm_url = node->as_string();
    if (config.lcm_url.empty()) node->fail("empty LCM URL");
  }
  if (auto node = section.optional("state_decimation")) {
    config.state_decimation = static_cast<int>(node->as_integer_in(1, 1000000));
  }
  auto capacity = [&section](const char* key, std::size_t& value) {
    if (auto node = section.optional(key)) {
      const long n = node->as_integer_in(1, 1L << 20);
      if (!is_power_of_two(static_cast<std::size_t>(n))) node->fail(std::to_string(n) + " is not a power of two");
      value = static_cast<std::size_t>(n);
    }
  };
  capacity("state_queue_capacity", config.state_queue_capacity);
  capacity("status_queue_capacity", config.status_queue_capacity);
  capacity("event_queue_capacity", config.event_queue_capacity);
  capacity("command_queue_capacity", config.command_queue_capacity);
  capacity("ack_queue_capacity", config.ack_queue_capacity);
  if (auto node = section.optional("idle_period_s")) config.idle_period_s = node->as_double_in(1e-4, 1.0);
  return config;
}

// ---- publisher ---------------------------------------------------------------

TelemetryPublisher::TelemetryPublisher(const TelemetryConfig& config, TelemetrySink& sink)
    : config_(validated(config)),
      states_(config_.state_queue_capacity),
      statuses_(config_.status_queue_capacity),
      events_(config_.event_queue_capacity),
      acks_(config_.ack_queue_capacity),
      commands_(config_.command_queue_capacity) {
  sinks_.push_back(&sink);
}

TelemetryPublisher::TelemetryPublisher(const TelemetryConfig& config)
    : config_(validated(config)),
      states_(config_.state_queue_capacity),
      statuses_(config_.status_queue_capacity),
      events_(config_.event_queue_capacity),
      acks_(config_.ack_queue_capacity),
      commands_(config_.command_queue_capacity) {
  lcm_ = std::make_unique<lcm::LCM>(with_receive_buffer(config_.lcm_url));
  if (!lcm_->good()) {
    throw std::runtime_error("telemetry: cannot open LCM at '" + config_.lcm_url +
                             "' (udpm needs a multicast route, see docs/telemetry.md)");
  }
  lcm_sink_ = std::make_unique<LcmSink>(*lcm_);
  sinks_.push_back(lcm_sink_.get());
  lcm_->subscribe(kCommandChannel, &TelemetryPublisher::on_command, this);
}

TelemetryPublisher::~TelemetryPublisher() { stop(); }

void TelemetryPublisher::add_sink(TelemetrySink& sink) {
  if (thread_.joinable()) throw std::logic_error("TelemetryPublisher::add_sink: the publisher runs already");
  const std::lock_guard lock(sink_mutex_);
  sinks_.push_back(&sink);
}

void TelemetryPublisher::start() {
  if (thread_.joinable()) throw std::logic_error("TelemetryPublisher::start: the publisher runs already");
  stop_requested_.store(false, std::memory_order_release);
  thread_ = std::thread(&TelemetryPublisher::run, this);
}

void TelemetryPublisher::stop() {
  if (!thread_.joinable()) return;
  stop_requested_.store(true, std::memory_order_release);
  thread_.join();
}

bool TelemetryPublisher::push_state(const ServoStateSample& sample) noexcept {
  if (config_.state_decimation > 1 && sample.cycle % config_.state_decimation != 0) return true;
  if (states_.try_push(sample)) {
    states_pushed_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }
  states_dropped_.fetch_add(1, std::memory_order_relaxed);
  return false;
}

bool TelemetryPublisher::push_status(const ServoStatusSample& sample) noexcept {
  if (statuses_.try_push(sample)) return true;
  statuses_dropped_.fetch_add(1, std::memory_order_relaxed);
  return false;
}

bool TelemetryPublisher::push_event(const ServoEventSample& sample) noexcept {
  if (events_.try_push(sample)) return true;
  events_dropped_.fetch_add(1, std::memory_order_relaxed);
  return false;
}

bool TelemetryPublisher::push_ack(const ServoCommandAck& ack) noexcept {
  if (acks_.try_push(ack)) return true;
  acks_dropped_.fetch_add(1, std::memory_order_relaxed);
  return false;
}

bool TelemetryPublisher::poll_command(ServoCommand& out) noexcept { return commands_.try_pop(out); }

TelemetryCounters TelemetryPublisher::counters() const noexcept {
  TelemetryCounters c;
  c.states_pushed = states_pushed_.load(std::memory_order_relaxed);
  c.states_dropped = states_dropped_.load(std::memory_order_relaxed);
  c.statuses_dropped = statuses_dropped_.load(std::memory_order_relaxed);
  c.events_dropped = events_dropped_.load(std::memory_order_relaxed);
  c.acks_dropped = acks_dropped_.load(std::memory_order_relaxed);
  c.published = published_.load(std::memory_order_relaxed);
  c.publish_failures = publish_failures_.load(std::memory_order_relaxed);
  c.commands_received = commands_received_.load(std::memory_order_relaxed);
  c.commands_rejected = commands_rejected_.load(std::memory_order_relaxed);
  return c;
}

template <typename Message>
void TelemetryPublisher::publish_to_sinks(const char* channel, const Message& message, std::int64_t utime) {
  std::vector<std::uint8_t> buffer(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
  const std::lock_guard lock(sink_mutex_);
  std::int64_t failures = 0;
  for (TelemetrySink* sink : sinks_) {
    try {
      sink->publish(channel, buffer, utime);
    } catch (const std::exception&) {
      ++failures;  // counted, reported in counters(); the publisher must keep going
    }
  }
  if (failures == 0) {
    published_.fetch_add(1, std::memory_order_relaxed);
  } else {
    publish_failures_.fetch_add(failures, std::memory_order_relaxed);
  }
}

void TelemetryPublisher::publish_ack(std::int64_t sequence, bool accepted, std::string_view text) {
  clm_lcm::servo_command_ack_t message;
  message.utime = wall_clock_utime();
  message.sequence = sequence;
  message.accepted = accepted;
  message.text = std::string(text);
  publish_to_sinks(kCommandAckChannel, message, message.utime);
}

bool TelemetryPublisher::submit_command(const clm_lcm::servo_command_t& message) {
  commands_received_.fetch_add(1, std::memory_order_relaxed);
  ServoCommand command;
  std::string reason = to_command(message, command);
  if (reason.empty()) {
    bool queued = false;
    {
      const std::lock_guard lock(command_mutex_);
      queued = commands_.try_push(command);
    }
    if (queued) return true;
    reason = "command queue full (" + std::to_string(commands_.capacity()) + "): the servo cycle is not taking commands";
  }
  commands_rejected_.fetch_add(1, std::memory_order_relaxed);
  publish_ack(message.sequence, false, reason);
  return false;
}

void TelemetryPublisher::on_command(const lcm::ReceiveBuffer* buffer, const std::string& /*channel*/) {
  // Runs inside lcm_handle (C frames): nothing may propagate out of here.
  try {
    clm_lcm::servo_command_t message;
    const int size = static_cast<int>(buffer->data_size);
    if (message.decode(buffer->data, 0, size) != size) {
      commands_received_.fetch_add(1, std::memory_order_relaxed);
      commands_rejected_.fetch_add(1, std::memory_order_relaxed);  // no sequence to answer to
      return;
    }
    submit_command(message);
  } catch (const std::exception&) {
    commands_rejected_.fetch_add(1, std::memory_order_relaxed);
  }
}

std::size_t TelemetryPublisher::drain() {
  // At most one queue's capacity per round each, so commands are still
  // handled while the cycle produces faster than the sinks take.
  std::size_t count = 0;
  auto drain_queue = [&](auto& queue, auto&& publish_one) {
    using Item = typename std::remove_reference_t<decltype(queue)>::value_type;
    Item item;
    for (std::size_t n = 0; n < queue.capacity() && queue.try_pop(item); ++n) {
      try {
        publish_one(item);
      } catch (const std::exception&) {
        publish_failures_.fetch_add(1, std::memory_order_relaxed);
      }
      ++count;
    }
  };
  drain_queue(events_, [&](const ServoEventSample& e) {
    const auto m = to_message(e);
    publish_to_sinks(kEventChannel, m, m.utime);
  });
  drain_queue(acks_, [&](const ServoCommandAck& a) {
    const auto m = to_message(a);
    publish_to_sinks(kCommandAckChannel, m, m.utime);
  });
  drain_queue(statuses_, [&](const ServoStatusSample& s) {
    const auto m = to_message(s, counters().telemetry_dropped());
    publish_to_sinks(kStatusChannel, m, m.utime);
  });
  drain_queue(states_, [&](const ServoStateSample& s) {
    const auto m = to_message(s);
    publish_to_sinks(kStateChannel, m, m.utime);
  });
  return count;
}

void TelemetryPublisher::run() {
  const auto idle = std::chrono::duration<double>(config_.idle_period_s);
  const int idle_ms = std::max(1, static_cast<int>(std::lround(config_.idle_period_s * 1e3)));
  while (!stop_requested_.load(std::memory_order_acquire)) {
    const std::size_t published = drain();
    if (lcm_) {
      // Waits for a message at most idle_ms; returns at once when one is
      // there. Then takes whatever else is waiting (bounded, so publishing
      // goes on): the daemon's own states come back on the multicast socket,
      // and a receiver that takes one message per pass falls behind them
      // after a stall and loses commands in the overflow.
      int handled = lcm_->handleTimeout(published > 0 ? 0 : idle_ms);
      for (int k = 0; handled > 0 && k < 256; ++k) handled = lcm_->handleTimeout(0);
    } else if (published == 0) {
      std::this_thread::sleep_for(idle);
    }
  }
  // What the cycle queued before stop() still goes out.
  drain();
}

}  // namespace clm::telemetry
