#include "daemon/telemetry/publisher.hpp"

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <type_traits>

#include "daemon/telemetry/lcm_conversion.hpp"
#include "daemon/telemetry/wire_check.hpp"

namespace clm::telemetry {

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
  lcm_->subscribe(kStatusChannel, &TelemetryPublisher::on_status, this);
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

bool TelemetryPublisher::push_state(const servo::CycleRecord& record) noexcept {
  if (config_.state_decimation > 1 && record.cycle % config_.state_decimation != 0) return true;
  if (states_.try_push(record)) {
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

bool TelemetryPublisher::poll_command(servo::Command& out) noexcept { return commands_.try_pop(out); }

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
  c.commands_malformed = commands_malformed_.load(std::memory_order_relaxed);
  c.foreign_statuses = foreign_statuses_.load(std::memory_order_relaxed);
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

void TelemetryPublisher::publish_ack(std::int64_t sequence, std::int64_t client, bool accepted, std::string_view text) {
  ServoCommandAck ack;
  ack.sequence = sequence;
  ack.client = client;
  ack.accepted = accepted;
  ack.text.assign(text);
  const auto message = to_message(ack, config_.axis, config_.session);
  publish_to_sinks(kCommandAckChannel, message, message.utime);
}

void TelemetryPublisher::publish_event(const ServoEventSample& sample) {
  const auto message = to_message(sample);
  publish_to_sinks(kEventChannel, message, message.utime);
}

bool TelemetryPublisher::submit_command(const clm_lcm::servo_command_t& message) {
  commands_received_.fetch_add(1, std::memory_order_relaxed);
  servo::Command command;
  std::string reason = to_command(message, command);
  if (!reason.empty()) commands_malformed_.fetch_add(1, std::memory_order_relaxed);
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
  publish_ack(message.sequence, message.client, false, reason);
  return false;
}

void TelemetryPublisher::on_command(const lcm::ReceiveBuffer* buffer, const std::string& /*channel*/) {
  // Runs inside lcm_handle (C frames): nothing may propagate out of here.
  try {
    clm_lcm::servo_command_t message;
    const std::span<const std::uint8_t> datagram(static_cast<const std::uint8_t*>(buffer->data), buffer->data_size);
    if (!decode_checked(datagram, message).empty()) {
      // Not acked: its sequence, client and axis cannot be trusted.
      commands_received_.fetch_add(1, std::memory_order_relaxed);
      commands_rejected_.fetch_add(1, std::memory_order_relaxed);
      commands_malformed_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    submit_command(message);
  } catch (const std::exception&) {
    commands_rejected_.fetch_add(1, std::memory_order_relaxed);
  }
}

void TelemetryPublisher::on_status(const lcm::ReceiveBuffer* buffer, const std::string& /*channel*/) {
  try {
    clm_lcm::servo_status_t message;
    const std::span<const std::uint8_t> datagram(static_cast<const std::uint8_t*>(buffer->data), buffer->data_size);
    if (!decode_checked(datagram, message).empty()) return;  // not a status anyone can rely on
    if (message.axis != config_.axis || message.session == config_.session) return;
    foreign_statuses_.fetch_add(1, std::memory_order_relaxed);
    foreign_session_.store(message.session, std::memory_order_release);
  } catch (const std::exception&) {
    // A status that cannot be handled is ignored; the publisher goes on.
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
    const auto m = to_message(a, config_.axis, config_.session);
    publish_to_sinks(kCommandAckChannel, m, m.utime);
  });
  drain_queue(statuses_, [&](const ServoStatusSample& s) {
    const auto m = to_message(s, counters().telemetry_dropped());
    publish_to_sinks(kStatusChannel, m, m.utime);
  });
  drain_queue(states_, [&](const servo::CycleRecord& s) {
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
