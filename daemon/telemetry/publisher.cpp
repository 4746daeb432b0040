#include "daemon/telemetry/publisher.hpp"

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <tuple>
#include <type_traits>

#include "daemon/telemetry/lcm_conversion.hpp"
#include "daemon/servo/servo_cycle.hpp"
#include "daemon/telemetry/lcm_datagram.hpp"
#include "daemon/telemetry/message_mac.hpp"
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
  if (!config_.key) throw std::invalid_argument("telemetry: no command key to sign and authenticate with over LCM");
  // The URL is parsed first: an unusable one fails before anything opens.
  const UdpmAddress address = parse_udpm_url(config_.lcm_url);
  // Publishing only: this instance never subscribes or handles, so liblcm
  // never opens its receive socket nor reassembles anything (lcm_datagram.hpp).
  lcm_ = std::make_unique<lcm::LCM>(config_.lcm_url);
  if (!lcm_->good()) {
    throw std::runtime_error("telemetry: cannot open LCM at '" + config_.lcm_url +
                             "' (udpm needs a multicast route, see docs/telemetry.md)");
  }
  lcm_sink_ = std::make_unique<LcmSink>(*lcm_);
  sinks_.push_back(lcm_sink_.get());
  receiver_ = std::make_unique<UdpmReceiver>(address);
  datagram_.resize(kLcmShortMessageMaxBytes + 64);
}

std::size_t TelemetryPublisher::max_accepted_payload_bytes() noexcept {
  return std::max(max_wire_bytes(wire_layout(static_cast<const clm_lcm::servo_command_t*>(nullptr))),
                  max_wire_bytes(wire_layout(static_cast<const clm_lcm::servo_status_t*>(nullptr))));
}

void TelemetryPublisher::set_safety_latch(SafetyLatch& latch) {
  if (thread_.joinable()) throw std::logic_error("TelemetryPublisher::set_safety_latch: the publisher runs already");
  safety_latch_ = &latch;
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
  if (receiver_) receiver_thread_ = std::thread(&TelemetryPublisher::receive, this);
}

void TelemetryPublisher::stop() {
  if (!thread_.joinable()) return;
  stop_requested_.store(true, std::memory_order_release);
  if (receiver_thread_.joinable()) receiver_thread_.join();
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
  c.commands_unauthenticated = commands_unauthenticated_.load(std::memory_order_relaxed);
  c.foreign_statuses = foreign_statuses_.load(std::memory_order_relaxed);
  c.datagrams_dropped = datagrams_dropped_.load(std::memory_order_relaxed);
  c.safety_commands_latched = safety_latched_.load(std::memory_order_relaxed);
  return c;
}

template <typename Message>
void TelemetryPublisher::publish_to_sinks(const char* channel, const Message& message, std::int64_t utime) {
  std::vector<std::uint8_t> buffer(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
  if (config_.key) sign_encoded(*config_.key, channel, buffer);
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
  servo::CommandResult refusal = servo::CommandResult::kRejectedInvalid;  // when `reason` is set
  if (!reason.empty()) commands_malformed_.fetch_add(1, std::memory_order_relaxed);
  if (reason.empty() && safety_latch_ != nullptr && servo::is_safety_command(command.kind)) {
    const std::uint64_t ticket = safety_latch_->latch(command);
    if (ticket != 0) {
      safety_latched_.fetch_add(1, std::memory_order_relaxed);
      PendingSafetyAck oldest;
      bool full = false;
      {
        const std::lock_guard lock(safety_mutex_);
        full = pending_safety_count_ == pending_safety_.size();
        if (full) {
          oldest = pending_safety_[0];
          std::move(pending_safety_.begin() + 1, pending_safety_.end(), pending_safety_.begin());
          --pending_safety_count_;
        }
        pending_safety_[pending_safety_count_++] = {command.sequence, command.client, ticket};
      }
      if (full) ack_safety(oldest);
      flush_safety_acks();
      return true;
    }
  }
  if (reason.empty()) {
    bool queued = false;
    {
      const std::lock_guard lock(command_mutex_);
      queued = commands_.try_push(command);
    }
    if (queued) return true;
    reason = "command queue full (" + std::to_string(commands_.capacity()) + "): the servo cycle is not taking commands";
    refusal = servo::CommandResult::kRejectedQueueFull;
  }
  commands_rejected_.fetch_add(1, std::memory_order_relaxed);
  if (servo::is_command_kind(message.command) &&
      servo::is_safety_command(static_cast<servo::CommandKind>(message.command))) {
    safety_refusals_.record(wall_clock_utime(), static_cast<servo::CommandKind>(message.command), message.client,
                            message.sequence,
                            refusal, reason);
  }
  publish_ack(message.sequence, message.client, false, reason);
  return false;
}

void TelemetryPublisher::ack_safety(const PendingSafetyAck& pending) {
  publish_ack(pending.sequence, pending.client, true, servo::describe(servo::CommandResult::kAccepted));
}

void TelemetryPublisher::flush_safety_acks() {
  if (safety_latch_ == nullptr) return;
  std::array<PendingSafetyAck, std::tuple_size_v<decltype(pending_safety_)>> obeyed;
  std::size_t count = 0;
  {
    const std::lock_guard lock(safety_mutex_);
    if (pending_safety_count_ == 0) return;
    const std::uint64_t done = safety_latch_->obeyed();
    std::size_t kept = 0;
    for (std::size_t i = 0; i < pending_safety_count_; ++i) {
      if (pending_safety_[i].ticket <= done) {
        obeyed[count++] = pending_safety_[i];
      } else {
        pending_safety_[kept++] = pending_safety_[i];
      }
    }
    pending_safety_count_ = kept;
  }
  for (std::size_t i = 0; i < count; ++i) {
    try {
      ack_safety(obeyed[i]);
    } catch (const std::exception&) {
      // LCM refused the ack: the sender times out; the command was obeyed.
    }
  }
}

void TelemetryPublisher::receive() {
  while (!stop_requested_.load(std::memory_order_acquire)) {
    bool waiting = false;
    {
      const std::lock_guard lock(safety_mutex_);
      waiting = pending_safety_count_ > 0;
    }
    // 1 ms while an ack waits for the cycle, else short enough for stop().
    const long length = receiver_->receive(datagram_, waiting ? 1 : 20);
    if (length > 0) {
      if (static_cast<std::size_t>(length) > datagram_.size()) {
        datagrams_dropped_.fetch_add(1, std::memory_order_relaxed);  // longer than any LCM short message
      } else {
        on_datagram(std::span<const std::uint8_t>(datagram_.data(), static_cast<std::size_t>(length)));
      }
    } else if (length < 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));  // a socket error: do not spin
    }
    try {
      flush_safety_acks();
    } catch (const std::exception&) {
      // Acks are retried at the next pass.
    }
  }
}

void TelemetryPublisher::on_datagram(std::span<const std::uint8_t> datagram) {
  // Nothing is sized from a header here: a fragment's claimed size is only
  // counted, and the payload of a short message is read where it lies.
  const LcmDatagram checked = check_lcm_datagram(datagram);
  if (checked.kind != DatagramKind::kShort) {
    datagrams_dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (checked.channel == kCommandChannel) {
    on_command(checked.payload);
  } else if (checked.channel == kStatusChannel) {
    on_status(checked.payload);
  }
}

void TelemetryPublisher::on_command(std::span<const std::uint8_t> payload) {
  try {
    clm_lcm::servo_command_t message;
    if (!decode_checked(payload, message).empty()) {
      // Not acked: its sequence, client and axis cannot be trusted.
      commands_received_.fetch_add(1, std::memory_order_relaxed);
      commands_rejected_.fetch_add(1, std::memory_order_relaxed);
      commands_malformed_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    // A stop, quick stop or disable needs no key: anyone may stop the axis
    // (docs/servod.md, "Who may command the axis").
    const bool safety = servo::is_command_kind(message.command) &&
                        servo::is_safety_command(static_cast<servo::CommandKind>(message.command));
    if (!safety && config_.key && !verify_encoded(*config_.key, kCommandChannel, payload)) {
      commands_received_.fetch_add(1, std::memory_order_relaxed);
      commands_rejected_.fetch_add(1, std::memory_order_relaxed);
      commands_unauthenticated_.fetch_add(1, std::memory_order_relaxed);
      publish_ack(message.sequence, message.client, false,
                  "unauthenticated: the command's mac is not that of the operators' key (commands.key_file)");
      return;
    }
    submit_command(message);
  } catch (const std::exception&) {
    commands_rejected_.fetch_add(1, std::memory_order_relaxed);
  }
}

void TelemetryPublisher::on_status(std::span<const std::uint8_t> payload) {
  try {
    clm_lcm::servo_status_t message;
    if (!decode_checked(payload, message).empty()) return;  // not a status anyone can rely on
    if (config_.key && !verify_encoded(*config_.key, kStatusChannel, payload)) return;  // not a daemon's
    if (message.axis != config_.axis || message.session == config_.session) return;
    foreign_statuses_.fetch_add(1, std::memory_order_relaxed);
    foreign_session_.store(message.session, std::memory_order_release);
  } catch (const std::exception&) {
    // A status that cannot be handled is ignored; the receiver goes on.
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
  while (!stop_requested_.load(std::memory_order_acquire)) {
    if (drain() == 0) std::this_thread::sleep_for(idle);
  }
  // What the cycle queued before stop() still goes out.
  drain();
}

}  // namespace clm::telemetry
