#include "daemon/servod/command_server.hpp"

#include <chrono>
#include <cstdio>
#include <exception>
#include <stdexcept>

namespace clm::servod {
namespace {

// collect_garbage about every 100 passes (0.2 s at the default poll period).
constexpr std::int64_t kGarbagePasses = 100;

/// The sequence of commands the server makes itself (the disable when
/// another daemon drives the axis): client 0, never acked.
constexpr std::int64_t kOwnSequence = -1;

bool own_command(const CommandReply& reply) { return reply.client == 0 && reply.sequence == kOwnSequence; }

}  // namespace

CommandClass command_class(servo::CommandKind kind) noexcept { return servo::route(kind).command_class; }

CommandServer::CommandServer(telemetry::TelemetryPublisher& publisher, ServoDaemon& daemon, double poll_period_s)
    : publisher_(publisher), daemon_(daemon), poll_period_s_(poll_period_s) {
  if (!(poll_period_s > 0.0)) throw std::invalid_argument("CommandServer: poll_period_s must be positive");
}

CommandServer::CommandServer(telemetry::TelemetryPublisher& publisher, ServoDaemon& daemon,
                             CommandGateSettings authority, double poll_period_s)
    : CommandServer(publisher, daemon, poll_period_s) {
  gate_.emplace(std::move(authority));
}

CommandServer::~CommandServer() { stop(); }

void CommandServer::start() {
  if (thread_.joinable()) throw std::logic_error("CommandServer::start: already running");
  stop_requested_.store(false, std::memory_order_release);
  thread_ = std::thread([this] {
    const auto pause = std::chrono::duration<double>(poll_period_s_);
    while (!stop_requested_.load(std::memory_order_acquire)) {
      if (serve_once() == 0) std::this_thread::sleep_for(pause);
    }
  });
}

void CommandServer::stop() {
  stop_requested_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

void CommandServer::ack(const CommandReply& reply, int& acks) {
  ack(reply.sequence, reply.client, reply.accepted(), reply.text(), acks);
}

void CommandServer::ack(std::int64_t sequence, std::int64_t client, bool accepted, const std::string& text, int& acks) {
  try {
    publisher_.publish_ack(sequence, client, accepted, text);
  } catch (const std::exception&) {
    // LCM refused the ack: the sender times out; the daemon goes on.
  }
  ++acks;
}

void CommandServer::record_safety_refusal(const servo::Command& command, const CommandReply& reply) {
  if (reply.accepted() || !servo::is_safety_command(command.kind)) return;
  publisher_.safety_refusals().record(telemetry::wall_clock_utime(), command.kind, command.client, command.sequence,
                                      reply.result,
                                      reply.detail.empty() ? std::string_view(servo::describe(reply.result))
                                                           : std::string_view(reply.detail));
}

void CommandServer::check_other_daemon() {
  const std::int64_t other = publisher_.foreign_session();
  if (other == 0 || other == other_session_handled_) return;
  other_session_handled_ = other;
  servo::Command disable;
  disable.kind = servo::CommandKind::kDisable;
  disable.sequence = kOwnSequence;
  disable.client = 0;
  daemon_.submit(disable);
  telemetry::ServoEventSample event;
  event.code = static_cast<std::int16_t>(EventCode::kOtherSession);
  event.severity = 2;  // clm_lcm::servo_event_t::SEVERITY_ERROR
  char text[128];
  std::snprintf(text, sizeof(text), "axis %s is also driven by session %lld on this URL: axis disabled",
                publisher_.config().axis.c_str(), static_cast<long long>(other));
  event.text.assign(text);
  try {
    publisher_.publish_event(event);
  } catch (const std::exception&) {
    // The disable above is what matters; the status still names the conflict's effect.
  }
}

void CommandServer::check_deadman() {
  if (!gate_) return;
  const std::int64_t lapsed = gate_->take_lapsed_deadman(telemetry::wall_clock_utime());
  if (lapsed == 0) return;
  // Past every queue, as a stop: the next cycle stops the program and ends an experiment.
  daemon_.request_owner_gone();
  ++deadman_lapses_;
  telemetry::ServoEventSample event;
  event.code = static_cast<std::int16_t>(EventCode::kDeadmanLapsed);
  event.severity = 1;  // clm_lcm::servo_event_t::SEVERITY_WARNING
  char text[160];
  std::snprintf(text, sizeof(text),
                "client %lld sent nothing for %g s (deadman): axis stopped, experiment ended, control released",
                static_cast<long long>(lapsed), gate_->settings().deadman_timeout_s);
  event.text.assign(text);
  try {
    publisher_.publish_event(event);
  } catch (const std::exception&) {
    // The stop above is what matters; the status shows control released.
  }
}

int CommandServer::serve_once() {
  int acks = 0;
  servo::Command received;
  while (publisher_.poll_command(received)) {
    served_.fetch_add(1, std::memory_order_relaxed);
    const servo::CommandRoute& route = servo::route(received.kind);
    if (gate_) {
      check_deadman();  // a lapse first: never hidden by another client taking control
      const CommandOrigin origin{received.axis.view(), received.session, received.client, received.sequence,
                                 received.utime};
      const std::int64_t now_us = telemetry::wall_clock_utime();
      const bool deadman_holder = gate_->deadman() && gate_->holder(now_us) == received.client;
      const CommandReply decision = gate_->admit(origin, command_class(received.kind), now_us);
      if (!decision.accepted()) {
        record_safety_refusal(received, decision);
        ack(decision, acks);
        continue;
      }
      // A tool that ran a sequence hands the axis back as its deadman would:
      // stopped, in the service law.
      if (deadman_holder && received.kind == servo::CommandKind::kReleaseControl) daemon_.request_owner_gone();
    }
    if (route.answered_by == servo::AnsweredBy::kAuthority) {
      if (!gate_) {
        ack({received.sequence, received.client, servo::CommandResult::kRejectedInvalid,
             std::string(route.name) + ": no command authority in this process"},
            acks);
      } else if (received.kind == servo::CommandKind::kTakeControl ||
                 received.kind == servo::CommandKind::kRenewControl) {
        char text[96];
        std::snprintf(text, sizeof(text), "control %s, %slease %g s",
                      received.kind == servo::CommandKind::kTakeControl ? "taken" : "renewed",
                      gate_->deadman() ? "deadman " : "", gate_->lease_remaining_s(telemetry::wall_clock_utime()));
        ack(received.sequence, received.client, true, text, acks);
      } else {
        ack(received.sequence, received.client, true, "control released", acks);
      }
      continue;
    }
    const CommandReply reply = daemon_.submit(received);
    // A command the cycle or the loader answers is acked once, with its
    // decision (below).
    if (!reply.answered_later()) {
      record_safety_refusal(received, reply);
      ack(reply, acks);
    }
  }
  for (const CommandReply& reply : daemon_.take_replies()) {
    if (own_command(reply)) continue;
    ack(reply, acks);
  }
  check_deadman();
  check_other_daemon();
  if (++passes_ % kGarbagePasses == 0) daemon_.collect_garbage();
  return acks;
}

std::uint64_t CommandServer::latch(const servo::Command& command) noexcept {
  if (!servo::is_safety_command(command.kind)) return 0;
  if (gate_ && !gate_->admit_safety(command.axis.view())) return 0;
  served_.fetch_add(1, std::memory_order_relaxed);
  return daemon_.request_safety(command.kind);
}

void CommandServer::fill(telemetry::CommandAuthorityStatus& out) const noexcept {
  const telemetry::TelemetryCounters counters = publisher_.counters();
  out.refused_malformed = counters.commands_malformed;
  out.datagrams_dropped = counters.datagrams_dropped;
  out.refused_unauthenticated = counters.commands_unauthenticated;
  if (!gate_) return;
  const std::int64_t now = telemetry::wall_clock_utime();
  out.control_client = gate_->holder(now);
  out.control_lease_remaining_s = gate_->lease_remaining_s(now);
  using Result = servo::CommandResult;
  out.admitted = gate_->count(Result::kAccepted);
  out.refused_other_axis = gate_->count(Result::kRejectedOtherAxis);
  out.refused_other_session = gate_->count(Result::kRejectedOtherSession);
  out.refused_no_client = gate_->count(Result::kRejectedNoClient);
  out.refused_replayed = gate_->count(Result::kRejectedReplayed);
  out.refused_stale = gate_->count(Result::kRejectedStale);
  out.refused_not_in_control = gate_->count(Result::kRejectedNotInControl);
}

}  // namespace clm::servod
