#pragma once
// The one in-process answer to a command, from the command authority
// (command_gate.hpp) or the daemon (servo_daemon.hpp); the command server
// publishes it as the ack (servo_command_ack_t).

#include <cstdint>
#include <string>
#include <utility>

#include "daemon/servo/command_result.hpp"

namespace clm::servod {

/// The daemon's answer to one command (the one in-process reply type): its
/// result and, where describe()'s words are not the whole answer, a detail:
/// for a refusal the one line naming the value and the limit (or the file and
/// the rule), for get_parameter the value.
struct CommandReply {
  CommandReply() = default;
  CommandReply(std::int64_t sequence_, std::int64_t client_, servo::CommandResult result_, std::string detail_ = "")
      : sequence(sequence_), client(client_), result(result_), detail(std::move(detail_)) {}

  std::int64_t sequence = 0;
  std::int64_t client = 0;  ///< the command's client, for the ack
  servo::CommandResult result = servo::CommandResult::kRejectedInvalid;
  std::string detail;

  bool accepted() const noexcept { return servo::is_accepted(result); }
  /// kQueued or kLoading: the cycle or the loader answers later (take_replies);
  /// this reply is not an answer.
  bool answered_later() const noexcept { return servo::answered_later(result); }
  /// The ack's text: the detail, else describe(result); after "rejected: " for a refusal.
  std::string text() const {
    std::string words = detail.empty() ? std::string(servo::describe(result)) : detail;
    return accepted() ? words : "rejected: " + words;
  }
};

}  // namespace clm::servod
