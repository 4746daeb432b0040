#pragma once
// Command authority (docs/servod.md, "Command authority"). Every command that
// reaches clm-servod names the axis and the daemon session it is meant for,
// the client that sends it, a sequence number that increases per client and
// the sender's wall-clock time. The gate admits a command only when
//   1. it is for this axis and this session (a log recorded against an
//      earlier run of the daemon names an older session);
//   2. its client is not 0 and its sequence is above the last one admitted
//      from that client (a repeated or replayed datagram is not);
//   3. it is at most max_age_s old (and not from further in the future);
//   4. for anything but stop, quick stop and disable: its client holds
//      control. take_control grants control when nobody else holds an
//      unexpired lease; every admitted command of the holder renews the lease;
//      release_control gives it up.
// A stop, a quick stop or a disable passes 1–3 from any client: stopping is
// never refused for lack of control. Refusals are counted by kind.
//
// Pure logic on the command thread: no I/O, no clock of its own (the caller
// passes the time). The counters and the holder are atomics, so the status can
// read them from another thread.

#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>

namespace clm::servod {

/// What a command asks of the gate.
enum class CommandClass : std::uint8_t {
  kSafety,          ///< stop, quick stop, disable: obeyed from any client
  kRead,            ///< get_parameter: changes nothing, answered for any client
  kTakeControl,
  kReleaseControl,
  kControlled,      ///< everything else: the sender must hold control
};

/// Who sent a command, for whom, and when.
struct CommandOrigin {
  std::string_view axis;
  std::int64_t session = 0;
  std::int64_t client = 0;
  std::int64_t sequence = 0;
  std::int64_t utime_us = 0;  ///< sender's wall-clock time [µs since the UNIX epoch]
};

/// Why the gate refused a command; kAdmitted when it did not.
enum class GateRefusal : std::uint8_t {
  kAdmitted,
  kOtherAxis,
  kOtherSession,
  kNoClient,      ///< client 0, or too many clients at once
  kReplayed,      ///< sequence not above the client's last admitted one
  kStale,         ///< older than max_age_s, or from the future
  kNotInControl,  ///< another client holds control, or nobody does
};
inline constexpr std::size_t kGateRefusalKinds = 7;
const char* name(GateRefusal refusal) noexcept;

struct CommandGateSettings {
  std::string axis;              ///< this daemon's axis name
  std::int64_t session = 0;      ///< this run's session id, non-zero
  double max_age_s = 2.0;        ///< oldest command admitted [s]
  double control_lease_s = 30.0; ///< control lapses this long after the holder's last command [s]
  /// Validates; throws std::invalid_argument naming the field.
  void validate() const;
};

struct GateDecision {
  GateRefusal refusal = GateRefusal::kAdmitted;
  std::string reason;  ///< one line; empty when admitted
  bool admitted() const noexcept { return refusal == GateRefusal::kAdmitted; }
};

class CommandGate {
 public:
  explicit CommandGate(CommandGateSettings settings);

  /// Decides on one command at wall-clock time `now_us`. Admitting take_control
  /// or release_control changes the holder; admitting any command records its
  /// sequence and, from the holder, renews the lease.
  GateDecision admit(const CommandOrigin& origin, CommandClass command_class, std::int64_t now_us);

  /// The client holding control at `now_us`, 0 for nobody.
  std::int64_t holder(std::int64_t now_us) const noexcept;
  /// Lease left to the holder at `now_us` [s], 0 when nobody holds control.
  double lease_remaining_s(std::int64_t now_us) const noexcept;
  /// Refusals so far of one kind (kAdmitted: commands admitted).
  std::int64_t count(GateRefusal refusal) const noexcept;
  const CommandGateSettings& settings() const noexcept { return settings_; }

 private:
  struct Client {
    std::int64_t id = 0;
    std::int64_t last_sequence = 0;
    std::int64_t last_seen_us = 0;
  };
  GateDecision refuse(GateRefusal refusal, std::string reason);
  /// The client's slot, or nullptr when every slot is in recent use.
  Client* client_slot(std::int64_t id, std::int64_t now_us);

  CommandGateSettings settings_;
  /// Clients seen recently. A client seen more than max_age_s ago may be
  /// forgotten to make room: any replay of its datagrams is then refused as
  /// stale. With every slot taken by a client seen within max_age_s, a new
  /// client is refused (kNoClient).
  std::array<Client, 32> clients_{};
  std::atomic<std::int64_t> holder_{0};
  std::atomic<std::int64_t> lease_end_us_{0};
  std::array<std::atomic<std::int64_t>, kGateRefusalKinds> counts_{};
};

}  // namespace clm::servod
