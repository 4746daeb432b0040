#include "tools/servod_client/client.hpp"

#include <lcm/lcm-cpp.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "clm_lcm/servo_command_ack_t.hpp"
#include "config/command_key.hpp"
#include "daemon/servo/command.hpp"
#include "daemon/telemetry/message_mac.hpp"
#include "tools/servod_client/stop_signals.hpp"

namespace clm::servod_client {

std::string lcm_url_or(const std::string& fallback) {
  const char* url = std::getenv("CLM_SERVO_LCM_URL");
  return url != nullptr && *url != '\0' ? std::string(url) : fallback;
}

std::string default_lcm_url() { return lcm_url_or(std::string(telemetry::kDefaultLcmUrl)); }

namespace {

using clm_lcm::servo_state_t;
using clm_lcm::servo_status_t;

constexpr std::int8_t kStateFault = servo_status_t::STATE_FAULT;

std::chrono::duration<double> duration(double value_s) { return std::chrono::duration<double>(value_s); }

}  // namespace

std::string seconds(double value_s) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g s", value_s);
  return text;
}

servo::Command make_command(servo::CommandKind kind) { return {.kind = kind}; }

bool needs_control(servo::CommandKind kind) {
  // The daemon's command table: its class for the command authority.
  return servo::route(kind).command_class == servo::CommandClass::kControlled;
}

namespace {

/// FNV-1a-64 of `prefix` "UID@HOSTNAME", as a positive int64, never 0.
std::int64_t client_id_of(const std::string& prefix) {
  char host[256] = {};
  if (::gethostname(host, sizeof(host) - 1) != 0) host[0] = '\0';
  const std::string text = prefix + std::to_string(::getuid()) + "@" + host;
  std::uint64_t hash = 0xcbf29ce484222325ULL;  // FNV-1a-64 offset basis
  for (const unsigned char c : text) {
    hash ^= c;
    hash *= 0x100000001b3ULL;  // FNV-1a-64 prime
  }
  const auto id = static_cast<std::int64_t>(hash & 0x7fffffffffffffffULL);
  return id != 0 ? id : 1;
}

}  // namespace

std::int64_t default_client_id() { return client_id_of(""); }

std::int64_t commission_client_id() { return client_id_of("commission:"); }

Client::Client(Options options)
    : options_(std::move(options)),
      client_id_(options_.client_id != 0 ? options_.client_id : default_client_id()),
      key_(load_command_key(options_.key_file.empty() ? default_command_key_path() : options_.key_file)) {
  lcm_ = std::make_unique<lcm::LCM>(options_.every_state ? telemetry::with_receive_buffer(options_.lcm_url)
                                                         : options_.lcm_url);
  if (!lcm_->good()) {
    throw Error("cannot open LCM at '" + options_.lcm_url +
                "' (for udpm a multicast route is needed: docs/telemetry.md)");
  }
  lcm::Subscription* subscription = lcm_->subscribe(options_.channels, &Client::on_message, this);
  // LCM drops what a subscription has queued beyond its capacity, 30
  // messages by default: 30 ms of states. A receiving thread descheduled
  // longer on a loaded host lost bursts of 14 to 300 states that the daemon
  // had published and the kernel had delivered. A minute of states at 1 kHz.
  if (options_.every_state) subscription->setQueueCapacity(60000);
  receiver_ = std::thread([this] { receive_loop(); });
}

Client::~Client() {
  stop_deadman();
  stop_.store(true);
  if (receiver_.joinable()) receiver_.join();
}

void Client::receive_loop() {
  while (!stop_.load()) {
    lcm_->handleTimeout(50);
    // A stop signal wakes every wait within 50 ms, messages or not.
    if (stop_signal() != 0) changed_.notify_all();
  }
}

void Client::start_deadman() {
  std::lock_guard lock(mutex_);
  if (renewing_) return;
  renewing_ = true;
  renewer_ = std::thread([this] { renew_loop(); });
}

void Client::stop_deadman() {
  {
    std::lock_guard lock(mutex_);
    renewing_ = false;
  }
  changed_.notify_all();
  if (renewer_.joinable()) renewer_.join();
}

void Client::renew_loop() {
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(duration(kDeadmanRenewPeriod_s));
  for (auto next = std::chrono::steady_clock::now();; next += period) {
    // Stopped, or a stop signal: no more renewals, the daemon's deadman takes over.
    if (stop_signal() != 0) return;
    std::optional<Target> to;
    {
      std::lock_guard lock(mutex_);
      if (!renewing_) return;
      to = target_;
    }
    if (to) {
      servo::Command renew = make_command(servo::CommandKind::kRenewControl);
      try {
        publish(renew, *to, false, "RENEW_CONTROL");
      } catch (const Error&) {
        // LCM refused this one; the next may pass, else the deadman runs out as it should.
      }
    }
    std::unique_lock lock(mutex_);
    changed_.wait_until(lock, next + period, [&] { return !renewing_ || stop_signal() != 0; });
  }
}

bool Client::reported(const servo_status_t& status) const {
  if (!options_.axis.empty()) return status.axis == options_.axis;
  if (target_) return status.axis == target_->axis;
  return true;
}

void Client::on_message(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  const auto* bytes = static_cast<const std::uint8_t*>(buffer->data);
  ReceivedMessage message{channel, buffer->recv_utime, std::vector<std::uint8_t>(bytes, bytes + buffer->data_size)};
  const bool daemons = channel == telemetry::kStateChannel || channel == telemetry::kStatusChannel ||
                       channel == telemetry::kEventChannel || channel == telemetry::kCommandAckChannel;
  std::lock_guard lock(mutex_);
  if (daemons && !telemetry::verify_encoded(key_, channel, message.data)) {
    ++unauthenticated_;
    return;  // not the daemon's: nothing of it is kept, not even in a capture
  }
  bool well_formed = true;
  if (channel == telemetry::kStateChannel) {
    servo_state_t state;
    if ((well_formed = decode(message.data, state))) {
      state_ = std::move(state);
      ++states_seen_;
    }
  } else if (channel == telemetry::kStatusChannel) {
    servo_status_t status;
    if ((well_formed = decode(message.data, status))) {
      const double age_s = static_cast<double>(telemetry::wall_clock_utime() - status.utime) * 1e-6;
      if (!(std::fabs(age_s) <= kMaxStatusAge_s)) {
        ++unauthenticated_;
        return;  // a replay of an old status, or a clock far off: not kept
      }
      if (axes_.size() < 64 || axes_.count(status.axis) > 0) {
        AxisStatus& heard = axes_[status.axis];
        heard.status = status;
        heard.received_utime = message.utime;
        ++heard.count;
      }
      if (reported(status)) {
        if (!first_status_) first_status_ = status;
        status_ = std::move(status);
        ++statuses_seen_;
      }
    }
  } else if (channel == telemetry::kEventChannel) {
    clm_lcm::servo_event_t event;
    if ((well_formed = decode(message.data, event))) event_ = std::move(event);
  } else if (channel == telemetry::kCommandAckChannel) {
    clm_lcm::servo_command_ack_t ack;
    if ((well_formed = decode(message.data, ack))) {
      // Only our own commands' acks: other clients' would pile up.
      if (pending_.count(ack.sequence) > 0 && ack.client == client_id_ && target_ && ack.axis == target_->axis &&
          ack.session == target_->session) {
        acks_[ack.sequence] = Ack{ack.sequence, ack.axis, ack.session, ack.client, static_cast<bool>(ack.accepted), ack.text};
      }
    }
  } else if (channel == telemetry::kCommandChannel) {
    clm_lcm::servo_command_t command;
    well_formed = decode(message.data, command);
  }
  if (!well_formed) {
    ++undecodable_;
    return;  // nothing of it is kept, not even in a capture
  }
  if (capturing_) captured_.push_back(std::move(message));
  changed_.notify_all();
}

/// Wall-clock µs × 1000 + a random 0..999: no other client is likely to use
/// the same sequence at the same time (positive, < 2^63 until 2262).
/// Above the last one this client used, so increasing also within a microsecond.
std::int64_t Client::fresh_sequence() {
  last_sequence_ =
      std::max(last_sequence_ + 1, telemetry::wall_clock_utime() * 1000 + static_cast<std::int64_t>(random_() % 1000));
  return last_sequence_;
}

Target Client::target(double timeout_s, bool only_axis) {
  std::unique_lock lock(mutex_);
  if (target_) return *target_;
  const std::string& wanted = options_.axis;
  const auto heard = [&] { return wanted.empty() ? !axes_.empty() : axes_.count(wanted) > 0; };
  if (!changed_.wait_for(lock, duration(timeout_s), heard)) {
    throw Timeout(std::string("no ") + telemetry::kStatusChannel + (wanted.empty() ? "" : " of axis '" + wanted + "'") +
                  " on " + options_.lcm_url + " within " + seconds(timeout_s) +
                  " (is clm-servod running with that lcm_url?)");
  }
  if (wanted.empty() && only_axis) {
    // Other daemons on the URL publish their statuses about as often: listen
    // until the first axis's next status (one status period), at most 1 s.
    const std::string first = axes_.begin()->first;
    const std::int64_t seen = axes_.begin()->second.count;
    changed_.wait_for(lock, std::chrono::seconds(1), [&] { return axes_.size() > 1 || axes_.at(first).count > seen; });
    if (axes_.size() > 1) {
      std::string names;
      for (const auto& [axis, status] : axes_) names += (names.empty() ? "'" : ", '") + axis + "'";
      throw SeveralAxes("several axes answer on " + options_.lcm_url + ": " + names + "; choose one with --axis");
    }
  }
  const AxisStatus& chosen = wanted.empty() ? axes_.begin()->second : axes_.at(wanted);
  target_ = Target{chosen.status.axis, chosen.status.session};
  if (!status_ || status_->axis != target_->axis) {
    first_status_ = chosen.status;
    status_ = chosen.status;
  }
  return *target_;
}

bool Client::holds_control(double margin_s) const {
  std::lock_guard lock(mutex_);
  if (!target_) return false;
  const auto found = axes_.find(target_->axis);
  if (found == axes_.end()) return false;
  const servo_status_t& status = found->second.status;
  if (status.session != target_->session || status.control_client != client_id_) return false;
  const double since_s = static_cast<double>(telemetry::wall_clock_utime() - found->second.received_utime) * 1e-6;
  return status.control_lease_remaining_s - since_s > margin_s;
}

Target Client::target_for(double timeout_s, const std::string& what) {
  try {
    return target(timeout_s);
  } catch (const SeveralAxes&) {
    throw;
  } catch (const Timeout& e) {
    throw NoAck(std::string("no ") + telemetry::kCommandAckChannel + (what.empty() ? "" : " for " + what) + ": " +
                    e.what(),
                0);
  }
}

void Client::take_control(double timeout_s, const std::string& what) {
  const Target to = target_for(timeout_s, what);
  Ack ack = send_once(make_command(servo::CommandKind::kTakeControl), to, timeout_s,
                      what == "TAKE_CONTROL" ? what : "TAKE_CONTROL (for " + what + ")");
  if (!ack.accepted) {
    // The message first: the order in which arguments are evaluated is
    // unspecified, and the Ack moved first left the text empty.
    const std::string message = "clm-servod refused TAKE_CONTROL: " + ack.text;
    throw Refused(message, std::move(ack));
  }
}

void Client::release_control(double timeout_s) {
  command("RELEASE_CONTROL", make_command(servo::CommandKind::kReleaseControl), timeout_s);
}

void Client::stop_and_release(double timeout_s) {
  command("STOP", make_command(servo::CommandKind::kStop), timeout_s);
  release_control(timeout_s);
}

Ack Client::send(servo::Command command, double timeout_s, const std::string& what) {
  const Target to = target_for(timeout_s, what);
  bool renewing = false;
  {
    std::lock_guard lock(mutex_);
    renewing = renewing_;
  }
  // A deadman lease is kept by the renewals; one that ran out is not taken
  // again behind the daemon's back: the command is refused not_in_control.
  if (needs_control(command.kind) && !renewing && !holds_control()) {
    const std::string name = what.empty() ? "the command" : what;
    Ack taken = send_once(make_command(servo::CommandKind::kTakeControl), to, timeout_s,
                          "TAKE_CONTROL (for " + name + ")");
    if (!taken.accepted) {
      taken.text = "TAKE_CONTROL for " + name + ": " + taken.text;
      return taken;
    }
  }
  return send_once(std::move(command), to, timeout_s, what);
}

std::int64_t Client::publish(servo::Command& command, const Target& to, bool awaited, const std::string& what) {
  if (!command.axis.assign(to.axis)) throw Error("axis name longer than 32 characters: '" + to.axis + "'");
  command.session = to.session;
  command.client = client_id_;
  command.utime = telemetry::wall_clock_utime();
  {
    std::lock_guard lock(mutex_);
    command.sequence = fresh_sequence();
    if (awaited) pending_.insert(command.sequence);  // before publishing, so a fast ack is not missed
  }
  clm_lcm::servo_command_t message = telemetry::to_message(command);
  std::vector<std::uint8_t> encoded(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(encoded.data(), 0, static_cast<int>(encoded.size()));
  telemetry::sign_encoded(key_, telemetry::kCommandChannel, encoded);
  if (lcm_->publish(telemetry::kCommandChannel, encoded.data(), static_cast<unsigned int>(encoded.size())) != 0) {
    std::lock_guard lock(mutex_);
    pending_.erase(command.sequence);
    throw Error("LCM refused to publish " + (what.empty() ? std::string() : what + " ") + "on " +
                telemetry::kCommandChannel + " at " + options_.lcm_url);
  }
  return command.sequence;
}

Ack Client::send_once(servo::Command command, const Target& to, double timeout_s, const std::string& what) {
  const std::int64_t sequence = publish(command, to, true, what);
  const auto forget = [&] {
    std::lock_guard lock(mutex_);
    pending_.erase(sequence);
    acks_.erase(sequence);
  };
  std::unique_lock lock(mutex_);
  if (!changed_.wait_for(lock, duration(timeout_s), [&] { return acks_.count(sequence) > 0; })) {
    lock.unlock();
    forget();
    const std::string channel = telemetry::kCommandAckChannel;
    std::string hint = " (is clm-servod running with that lcm_url?)";
    if (const std::int64_t ignored = unauthenticated(); ignored > 0) {
      hint = " (" + std::to_string(ignored) +
             " messages without the operators' mac were ignored: does clm-servod use this key file?)";
    }
    if (what.empty()) {
      throw NoAck("no " + channel + " for sequence " + std::to_string(sequence) + " on " + options_.lcm_url +
                      " within " + seconds(timeout_s) + hint,
                  sequence);
    }
    throw NoAck("no " + channel + " for " + what + " (sequence " + std::to_string(sequence) + ") within " +
                    seconds(timeout_s) + " on " + options_.lcm_url + hint,
                sequence);
  }
  Ack ack = std::move(acks_[sequence]);
  acks_.erase(sequence);
  pending_.erase(sequence);
  return ack;
}

std::string Client::command(const std::string& what, servo::Command command, double timeout_s) {
  Ack ack = send(std::move(command), timeout_s, what);
  if (!ack.accepted) {
    const std::string message = "clm-servod refused " + what + ": " + ack.text;
    throw Refused(message, std::move(ack));
  }
  return ack.text;
}

servo_status_t Client::wait_for_status(double timeout_s) {
  std::unique_lock lock(mutex_);
  const std::int64_t returned = statuses_returned_;
  const bool came = changed_.wait_for(lock, duration(timeout_s), [&] { return stop_signal() != 0 || statuses_seen_ > returned; });
  throw_if_interrupted();
  if (!came) {
    throw Timeout(std::string("no ") + telemetry::kStatusChannel + " on " + options_.lcm_url + " within " +
                  seconds(timeout_s) + " (is clm-servod running with that lcm_url?)");
  }
  statuses_returned_ = statuses_seen_;
  return *status_;
}

std::string Client::fault_text() const {
  if (status_ && status_->fault != 0) {
    return "fault " + std::to_string(status_->fault) + " (" + status_->fault_reason + ") at cycle " +
           std::to_string(status_->fault_cycle);
  }
  return "a fault (CLM_SERVO_STATE state 2; see clm ctl status)";
}

void Client::wait_for_state(const std::string& what, double timeout_s,
                            const std::function<bool(const servo_state_t&)>& done) {
  std::unique_lock lock(mutex_);
  const bool finished = changed_.wait_for(lock, duration(timeout_s), [&] {
    return stop_signal() != 0 || (state_ && (state_->state == kStateFault || done(*state_)));
  });
  throw_if_interrupted();
  if (finished && state_->state == kStateFault) {
    // The status may trail the state by up to one status period.
    changed_.wait_for(lock, std::chrono::milliseconds(300), [&] { return status_ && status_->fault != 0; });
    throw Faulted("clm-servod latched " + fault_text() + " while waiting for " + what);
  }
  if (!finished) {
    std::string last = state_ ? "the last CLM_SERVO_STATE is of cycle " + std::to_string(state_->cycle)
                              : "no CLM_SERVO_STATE received on " + options_.lcm_url;
    if (undecodable_ > 0) {
      last += "; " + std::to_string(undecodable_) + " messages did not decode (a clm-servod built from other lcmtypes?)";
    }
    throw Timeout(what + ": not within " + seconds(timeout_s) + " (" + last + ")");
  }
}

void Client::wait_states(std::int64_t count, double timeout_s, const std::string& what) {
  std::unique_lock lock(mutex_);
  const std::int64_t target = states_seen_ + count;
  const bool came = changed_.wait_for(lock, duration(timeout_s), [&] { return stop_signal() != 0 || states_seen_ >= target; });
  throw_if_interrupted();
  if (!came) {
    throw Timeout(what + ": " + std::to_string(count) + " CLM_SERVO_STATE messages did not come within " +
                  seconds(timeout_s) + " on " + options_.lcm_url);
  }
  if (state_ && state_->state == kStateFault) throw Faulted("clm-servod latched " + fault_text() + " during " + what);
}

std::optional<servo_state_t> Client::latest_state() const {
  std::lock_guard lock(mutex_);
  return state_;
}

std::optional<servo_status_t> Client::first_status() const {
  std::lock_guard lock(mutex_);
  return first_status_;
}

std::optional<servo_status_t> Client::latest_status() const {
  std::lock_guard lock(mutex_);
  return status_;
}

std::optional<clm_lcm::servo_event_t> Client::latest_event() const {
  std::lock_guard lock(mutex_);
  return event_;
}

std::int64_t Client::undecodable() const {
  std::lock_guard lock(mutex_);
  return undecodable_;
}

std::int64_t Client::unauthenticated() const {
  std::lock_guard lock(mutex_);
  return unauthenticated_;
}

std::int64_t Client::states_received() const {
  std::lock_guard lock(mutex_);
  return states_seen_;
}

void Client::start_capture() {
  std::lock_guard lock(mutex_);
  captured_.clear();
  capturing_ = true;
}

std::vector<ReceivedMessage> Client::stop_capture() {
  std::lock_guard lock(mutex_);
  capturing_ = false;
  return std::exchange(captured_, {});
}

std::vector<ReceivedMessage> Client::take_captured() {
  std::lock_guard lock(mutex_);
  return std::exchange(captured_, {});
}

}  // namespace clm::servod_client
