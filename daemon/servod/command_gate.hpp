#pragma once
// Command authority (docs/servod.md, "Command authority"). Every command that
// reaches clm-servod names the axis and the daemon session it is meant for,
// the client that sends it, a sequence number that increases per client and
// the sender's wall-clock time. The gate admits
//   - a stop, a quick stop or a disable when it names this axis: nothing
//     else (no session, age, client, sequence, control, table slot), since
//     obeying one twice, late or from anyone changes nothing but stopping;
//   - a read (get_parameter) when it is for this axis and session, from a
//     client other than 0, at most max_age_s old: no client table either, as
//     answering it twice changes nothing;
//   - take_control, release_control and every other command when it also
//     passes the control check (take_control: nobody else holds an
//     unexpired lease; the others: its client holds control) and then the
//     replay check (its sequence is above the last one admitted from that
//     client). Every admitted command of the holder renews the lease;
//   - renew_control (the heartbeat of a tool that runs a sequence) when it
//     passes 1-4 and comes from the holder: no sequence is kept, so the
//     heartbeat thread never races the tool's other commands. It makes the
//     lease a deadman lease of deadman_timeout_s (renewed by every admitted
//     command of the holder); when one lapses, take_lapsed_deadman() hands
//     the holder to the command server once, which stops the axis.
// Only these last commands, once admitted, take a slot of the client table:
// reads, safety commands and refused commands never do, so traffic that
// anyone can send cannot fill it. A full table forgets the client seen
// longest ago and remembers the newest utime of any client forgotten: a
// client not in the table must send a utime above it, so a replay of a
// forgotten client's datagrams is refused as replayed, as it was before.
// Refusals are servo::CommandResult values (kRejectedOtherAxis …
// kRejectedNotInControl), counted by kind; a refusal's detail starts with the
// kind's counter name (gate_counter_name), as the status counts it.
//
// Pure logic on the command thread: no I/O, no clock of its own (the caller
// passes the time). The counters and the holder are atomics, so the status can
// read them from another thread.

#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>

#include "daemon/servo/command.hpp"
#include "daemon/servod/command_reply.hpp"

namespace clm::servod {

/// What a command asks of the gate: its row of servo::kCommandRoutes says.
using CommandClass = servo::CommandClass;

/// Who sent a command, for whom, and when.
struct CommandOrigin {
  std::string_view axis;
  std::int64_t session = 0;
  std::int64_t client = 0;
  std::int64_t sequence = 0;
  std::int64_t utime_us = 0;  ///< sender's wall-clock time [µs since the UNIX epoch]
};

/// What the gate answers: kAccepted (admitted) or one of its refusals.
inline constexpr std::array<servo::CommandResult, 7> kGateResults{
    servo::CommandResult::kAccepted,         servo::CommandResult::kRejectedOtherAxis,
    servo::CommandResult::kRejectedOtherSession, servo::CommandResult::kRejectedNoClient,
    servo::CommandResult::kRejectedReplayed,  servo::CommandResult::kRejectedStale,
    servo::CommandResult::kRejectedNotInControl,
};
/// The status counter of a gate result ("admitted", "other_axis",
/// "other_session", "no_client", "replayed", "stale", "not_in_control"); "" for another result.
const char* gate_counter_name(servo::CommandResult result) noexcept;

struct CommandGateSettings {
  std::string axis;              ///< this daemon's axis name
  std::int64_t session = 0;      ///< this run's session id, non-zero
  double max_age_s = 2.0;        ///< oldest command admitted [s]
  double control_lease_s = 30.0; ///< control lapses this long after the holder's last command [s]
  /// A deadman lease (after renew_control) lapses this long after the holder's last command [s].
  double deadman_timeout_s = 1.0;
  /// Validates; throws std::invalid_argument naming the field.
  void validate() const;
};

class CommandGate {
 public:
  explicit CommandGate(CommandGateSettings settings);

  /// Decides on one command at wall-clock time `now_us`: the reply to it,
  /// kAccepted when admitted (not yet an answer: the command goes on), else
  /// the refusal with its detail. Admitting take_control or release_control
  /// changes the holder; admitting a controlled command records its sequence
  /// and, from the holder, renews the lease.
  CommandReply admit(const CommandOrigin& origin, CommandClass command_class, std::int64_t now_us);
  /// The decision on a stop, quick stop or disable for `axis`, without a
  /// reason's text: true (and counted as admitted) when it names this axis.
  /// Any thread: no allocation, no lock, no table. admit() decides kSafety
  /// with this.
  bool admit_safety(std::string_view axis) noexcept;

  /// Command thread: when the holder's deadman lease has lapsed by `now_us`,
  /// forgets it and returns that client, once; else 0. Call it before admit()
  /// so that a lapse is never hidden by another client taking control.
  std::int64_t take_lapsed_deadman(std::int64_t now_us) noexcept;
  /// The holder's lease is a deadman lease (any thread).
  bool deadman() const noexcept { return deadman_.load(std::memory_order_acquire); }
  /// The client holding control at `now_us`, 0 for nobody.
  std::int64_t holder(std::int64_t now_us) const noexcept;
  /// Lease left to the holder at `now_us` [s], 0 when nobody holds control.
  double lease_remaining_s(std::int64_t now_us) const noexcept;
  /// Answers so far of one of kGateResults (kAccepted: commands admitted).
  std::int64_t count(servo::CommandResult result) const noexcept;
  const CommandGateSettings& settings() const noexcept { return settings_; }

 private:
  struct Client {
    std::int64_t id = 0;
    std::int64_t last_sequence = 0;
    std::int64_t last_utime_us = 0;  ///< sender's utime of its last admitted command
    std::int64_t last_seen_us = 0;
  };
  /// The refusal of `origin`'s command, counted; `reason`: what describe() does not say ("": nothing).
  CommandReply refuse(const CommandOrigin& origin, servo::CommandResult result, const std::string& reason = "");
  /// Counts one admitted command (any thread).
  void count_admitted() noexcept;
  /// The client's slot, nullptr when it has none.
  Client* find_client(std::int64_t id) noexcept;
  /// Records an admitted command of `origin`'s client, in its slot or in the
  /// slot of the client seen longest ago (which is forgotten).
  void record(Client* client, const CommandOrigin& origin, std::int64_t now_us) noexcept;

  CommandGateSettings settings_;
  /// Clients whose take_control, release_control or controlled command was
  /// admitted. Never full: the client seen longest ago makes room.
  std::array<Client, 32> clients_{};
  /// The newest utime of a command admitted from a client since forgotten.
  std::int64_t forgotten_utime_us_ = 0;
  std::atomic<std::int64_t> holder_{0};
  std::atomic<std::int64_t> lease_end_us_{0};
  std::atomic<bool> deadman_{false};
  std::array<std::atomic<std::int64_t>, kGateResults.size()> counts_{};
};

}  // namespace clm::servod
