#pragma once
// clm-servod's command thread (non-real-time): takes the checked commands
// the telemetry publisher received on CLM_SERVO_COMMAND, puts each through
// the command authority (CommandGate: axis, session, client, sequence, age,
// control; docs/servod.md "Command authority"), submits the admitted ones to
// the ServoDaemon and acknowledges each command with exactly one
// CLM_SERVO_COMMAND_ACK:
//
//   - refused by the gate: acked at once with the refusal and its reason;
//   - take_control, release_control (servo::AnsweredBy::kAuthority): acked
//     by the gate's decision, never submitted;
//   - every other command is acked with submit's reply, unless that says
//     the answer comes later (CommandReply::answered_later: queued for the
//     cycle, or its file being read on the loader thread); then with the
//     reply take_replies() delivers once the cycle has decided (a cycle
//     later; for a move_to, run_program or jog, once the cycle has taken its
//     program or said why not) or the loader has read the file.
//     servo::kCommandRoutes says which kinds the cycle answers.
//
// Stop, quick stop and disable from the network do not come here: the
// publisher's receiver hands them to latch() (telemetry::SafetyLatch), which
// asks the gate (the axis only) and latches them for the loop
// (ServoDaemon::request_safety); the receiver acks them once obeyed.
//
// When the publisher hears another session's status for this axis (a second
// daemon driving it), the server disables the axis and publishes an error
// event, once per other session.
//
// It is the only thread that calls poll_command (single consumer),
// ServoDaemon::submit (single producer of the cycle's command queue) and
// take_replies; it also frees retired programs and laws (collect_garbage).

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <thread>

#include "daemon/servod/command_gate.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "daemon/servod/telemetry_bridge.hpp"
#include "daemon/telemetry/telemetry.hpp"

namespace clm::servod {

/// What the gate asks of a command of `kind`: its class in servo::kCommandRoutes.
CommandClass command_class(servo::CommandKind kind) noexcept;

class CommandServer final : public AuthorityReport, public telemetry::SafetyLatch {
 public:
  /// Without command authority: every well-formed command is submitted
  /// (in-process use and tests); take/release control are refused.
  /// `poll_period_s`: how long the thread sleeps when there is nothing to do.
  CommandServer(telemetry::TelemetryPublisher& publisher, ServoDaemon& daemon, double poll_period_s = 0.002);
  /// With the command authority `authority` (throws std::invalid_argument
  /// for invalid settings, CommandGateSettings::validate).
  CommandServer(telemetry::TelemetryPublisher& publisher, ServoDaemon& daemon, CommandGateSettings authority,
                double poll_period_s = 0.002);
  /// stop().
  ~CommandServer();
  CommandServer(const CommandServer&) = delete;
  CommandServer& operator=(const CommandServer&) = delete;

  /// Starts the thread. std::logic_error when it runs already.
  void start();
  /// Stops and joins the thread; idempotent. Afterwards the caller may use
  /// ServoDaemon::submit and take_replies itself (shutdown).
  void stop();

  /// One pass, for tests and for running without a thread: every waiting
  /// command and every cycle reply, then garbage collection when due.
  /// Returns the acks published.
  int serve_once();

  std::int64_t commands_served() const noexcept { return served_.load(std::memory_order_relaxed); }
  /// Deadman leases that lapsed so far (command thread).
  std::int64_t deadman_lapses() const noexcept { return deadman_lapses_; }
  /// Commands admitted by the gate (or submitted, without one) that the daemon then refused.
  /// The gate; nullptr without command authority.
  const CommandGate* gate() const noexcept { return gate_ ? &*gate_ : nullptr; }
  /// The status's command part: holder, lease and every counter. Any thread; noexcept, no allocation.
  void fill(telemetry::CommandAuthorityStatus& out) const noexcept override;
  /// The publisher's receiver thread: a stop, quick stop or disable the gate
  /// admits (CommandGate::admit_safety) is latched for the loop
  /// (ServoDaemon::request_safety), past this thread and every queue.
  std::uint64_t latch(const servo::Command& command) noexcept override;
  std::uint64_t obeyed() const noexcept override { return daemon_.safety_obeyed(); }

 private:
  void ack(const CommandReply& reply, int& acks);
  void ack(std::int64_t sequence, std::int64_t client, bool accepted, const std::string& text, int& acks);
  /// A refusal of a stop, quick stop or disable goes to the publisher's
  /// SafetyRefusalLog (the journal); any other reply is left alone.
  void record_safety_refusal(const servo::Command& command, const CommandReply& reply);
  void check_other_daemon();
  /// A deadman lease that lapsed: the daemon stops the axis and ends an
  /// experiment (ServoDaemon::request_owner_gone); the holder is forgotten.
  void check_deadman();

  telemetry::TelemetryPublisher& publisher_;
  ServoDaemon& daemon_;
  std::optional<CommandGate> gate_;
  double poll_period_s_;
  std::int64_t passes_ = 0;
  std::int64_t other_session_handled_ = 0;
  std::int64_t deadman_lapses_ = 0;
  std::atomic<std::int64_t> served_{0};
  std::atomic<bool> stop_requested_{false};
  std::thread thread_;
};

}  // namespace clm::servod
