#include "daemon/servod/command_gate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace clm::servod {
namespace {

std::int64_t to_us(double seconds) { return static_cast<std::int64_t>(std::llround(seconds * 1e6)); }

/// The index of `result` in kGateResults.
std::size_t gate_index(servo::CommandResult result) noexcept {
  std::size_t k = 0;
  while (k + 1 < kGateResults.size() && kGateResults[k] != result) ++k;
  return k;
}

std::string seconds_text(double seconds) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g s", seconds);
  return buffer;
}

}  // namespace

const char* gate_counter_name(servo::CommandResult result) noexcept {
  using Result = servo::CommandResult;
  switch (result) {
    case Result::kAccepted: return "admitted";
    case Result::kRejectedOtherAxis: return "other_axis";
    case Result::kRejectedOtherSession: return "other_session";
    case Result::kRejectedNoClient: return "no_client";
    case Result::kRejectedReplayed: return "replayed";
    case Result::kRejectedStale: return "stale";
    case Result::kRejectedNotInControl: return "not_in_control";
    default: return "";
  }
}

void CommandGateSettings::validate() const {
  if (axis.empty()) throw std::invalid_argument("axis name is empty");
  if (session == 0) throw std::invalid_argument("session id is 0");
  if (!(max_age_s > 0.0 && max_age_s <= 3600.0)) {
    throw std::invalid_argument("max_age_s must be in (0, 3600], got " + std::to_string(max_age_s));
  }
  if (!(control_lease_s > 0.0 && control_lease_s <= 86400.0)) {
    throw std::invalid_argument("control_lease_s must be in (0, 86400], got " + std::to_string(control_lease_s));
  }
  if (!(deadman_timeout_s >= 0.5 && deadman_timeout_s <= 10.0)) {
    throw std::invalid_argument("deadman_timeout_s must be in [0.5, 10], got " + std::to_string(deadman_timeout_s));
  }
}

CommandGate::CommandGate(CommandGateSettings settings) : settings_(std::move(settings)) { settings_.validate(); }

CommandReply CommandGate::refuse(const CommandOrigin& origin, servo::CommandResult result, const std::string& reason) {
  counts_[gate_index(result)].fetch_add(1, std::memory_order_relaxed);
  std::string detail = std::string(gate_counter_name(result)) + ": " + (reason.empty() ? servo::describe(result) : reason);
  return {origin.sequence, origin.client, result, std::move(detail)};
}

void CommandGate::count_admitted() noexcept {
  counts_[gate_index(servo::CommandResult::kAccepted)].fetch_add(1, std::memory_order_relaxed);
}

CommandGate::Client* CommandGate::find_client(std::int64_t id) noexcept {
  for (Client& c : clients_) {
    if (c.id == id) return &c;
  }
  return nullptr;
}

void CommandGate::record(Client* client, const CommandOrigin& origin, std::int64_t now_us) noexcept {
  if (client == nullptr) {
    client = &clients_[0];
    for (Client& c : clients_) {
      if (c.last_seen_us < client->last_seen_us) client = &c;
    }
    if (client->id != 0) forgotten_utime_us_ = std::max(forgotten_utime_us_, client->last_utime_us);
    *client = Client{origin.client};
  }
  client->last_sequence = origin.sequence;
  client->last_utime_us = std::max(client->last_utime_us, origin.utime_us);
  client->last_seen_us = now_us;
}

bool CommandGate::admit_safety(std::string_view axis) noexcept {
  if (axis != settings_.axis) return false;
  count_admitted();
  return true;
}

CommandReply CommandGate::admit(const CommandOrigin& origin, CommandClass command_class, std::int64_t now_us) {
  using Result = servo::CommandResult;
  const CommandReply admitted{origin.sequence, origin.client, Result::kAccepted};
  if (command_class == CommandClass::kSafety && admit_safety(origin.axis)) return admitted;
  if (origin.axis != settings_.axis) {
    return refuse(origin, Result::kRejectedOtherAxis,
                  "for axis '" + std::string(origin.axis) + "', this daemon drives axis '" + settings_.axis + "'");
  }
  if (origin.session != settings_.session) {
    return refuse(origin, Result::kRejectedOtherSession, "for session " + std::to_string(origin.session) +
                                                  ", this daemon's session is " + std::to_string(settings_.session) +
                                                  " (read it from the status)");
  }
  if (origin.client == 0) return refuse(origin, Result::kRejectedNoClient);
  const double age_s = static_cast<double>(now_us - origin.utime_us) * 1e-6;
  if (std::fabs(age_s) > settings_.max_age_s) {
    return refuse(origin, Result::kRejectedStale, (age_s > 0 ? "sent " + seconds_text(age_s) + " ago"
                                                  : "sent " + seconds_text(-age_s) + " in the future") +
                                           ", the limit is " + seconds_text(settings_.max_age_s));
  }
  if (command_class == CommandClass::kRead) {
    count_admitted();
    return admitted;
  }
  const std::int64_t holder_now = holder(now_us);
  const bool holds = holder_now == origin.client;
  if (command_class == CommandClass::kRenewControl) {
    if (!holds) return refuse(origin, Result::kRejectedNotInControl);
    deadman_.store(true, std::memory_order_release);
    lease_end_us_.store(now_us + to_us(settings_.deadman_timeout_s), std::memory_order_release);
    count_admitted();
    return admitted;
  }
  if (command_class == CommandClass::kTakeControl && holder_now != 0 && !holds) {
    return refuse(origin, Result::kRejectedNotInControl, "client " + std::to_string(holder_now) + " holds control for another " +
                                                  seconds_text(lease_remaining_s(now_us)) + " unless it releases it");
  }
  if (command_class == CommandClass::kReleaseControl && !holds) {
    return refuse(origin, Result::kRejectedNotInControl);
  }
  if (command_class == CommandClass::kControlled && !holds) {
    return refuse(origin, Result::kRejectedNotInControl, holder_now == 0 ? std::string("take control first")
                                                              : "client " + std::to_string(holder_now) + " holds control");
  }
  Client* client = find_client(origin.client);
  const std::int64_t last_sequence = client != nullptr ? client->last_sequence : 0;
  if (origin.sequence <= last_sequence) {
    return refuse(origin, Result::kRejectedReplayed, "sequence " + std::to_string(origin.sequence) + " is not above " +
                                              std::to_string(last_sequence) + ", the last one of client " +
                                              std::to_string(origin.client));
  }
  if (client == nullptr && origin.utime_us <= forgotten_utime_us_) {
    return refuse(origin, Result::kRejectedReplayed, "sent no later than the last command of a client no longer tracked; "
                                          "send it again");
  }
  // A new holder starts with an ordinary lease; the holder's renewals keep its kind.
  if (!holds) deadman_.store(false, std::memory_order_release);
  const double lease_s = deadman() ? settings_.deadman_timeout_s : settings_.control_lease_s;
  switch (command_class) {
    case CommandClass::kTakeControl:
      // The lease first, so a reader never sees the new holder with an old lease.
      lease_end_us_.store(now_us + to_us(lease_s), std::memory_order_release);
      holder_.store(origin.client, std::memory_order_release);
      break;
    case CommandClass::kReleaseControl:
      holder_.store(0, std::memory_order_release);
      lease_end_us_.store(0, std::memory_order_release);
      deadman_.store(false, std::memory_order_release);
      break;
    default:
      lease_end_us_.store(now_us + to_us(lease_s), std::memory_order_release);
      break;
  }
  record(client, origin, now_us);
  count_admitted();
  return admitted;
}

std::int64_t CommandGate::take_lapsed_deadman(std::int64_t now_us) noexcept {
  const std::int64_t id = holder_.load(std::memory_order_acquire);
  if (!deadman() || id == 0 || now_us < lease_end_us_.load(std::memory_order_acquire)) return 0;
  holder_.store(0, std::memory_order_release);
  lease_end_us_.store(0, std::memory_order_release);
  deadman_.store(false, std::memory_order_release);
  return id;
}

std::int64_t CommandGate::holder(std::int64_t now_us) const noexcept {
  const std::int64_t id = holder_.load(std::memory_order_acquire);
  return id != 0 && now_us < lease_end_us_.load(std::memory_order_acquire) ? id : 0;
}

double CommandGate::lease_remaining_s(std::int64_t now_us) const noexcept {
  if (holder(now_us) == 0) return 0.0;
  return static_cast<double>(lease_end_us_.load(std::memory_order_acquire) - now_us) * 1e-6;
}

std::int64_t CommandGate::count(servo::CommandResult result) const noexcept {
  return counts_[gate_index(result)].load(std::memory_order_relaxed);
}

}  // namespace clm::servod
