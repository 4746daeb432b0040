#include "daemon/servod/command_server.hpp"

#include <chrono>
#include <exception>
#include <stdexcept>

namespace clm::servod {
namespace {

// collect_garbage about every 100 passes (0.2 s at the default poll period).
constexpr std::int64_t kGarbagePasses = 100;

}  // namespace

CommandServer::CommandServer(telemetry::TelemetryPublisher& publisher, ServoDaemon& daemon, double poll_period_s)
    : publisher_(publisher), daemon_(daemon), poll_period_s_(poll_period_s) {
  if (!(poll_period_s > 0.0)) throw std::invalid_argument("CommandServer: poll_period_s must be positive");
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

int CommandServer::serve_once() {
  int acks = 0;
  const auto ack = [&](const CommandReply& reply) {
    try {
      publisher_.publish_ack(reply.sequence, reply.client, reply.accepted, reply.text);
    } catch (const std::exception&) {
      // LCM refused the ack: the sender times out; the daemon goes on.
    }
    ++acks;
  };
  servo::Command received;
  while (publisher_.poll_command(received)) {
    served_.fetch_add(1, std::memory_order_relaxed);
    const CommandReply reply = daemon_.submit(received);
    // A command the cycle or the loader answers is acked once, with its
    // decision (below).
    if (!reply.answered_later && !(reply.accepted && servo::answered_by_cycle(received.kind))) ack(reply);
  }
  for (const CommandReply& reply : daemon_.take_replies()) ack(reply);
  if (++passes_ % kGarbagePasses == 0) daemon_.collect_garbage();
  return acks;
}

}  // namespace clm::servod
