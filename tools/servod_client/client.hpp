#pragma once
// A client of a running clm-servod over LCM (docs/servod.md "Commands" and
// "Command authority", docs/telemetry.md): receives CLM_SERVO_STATUS,
// CLM_SERVO_STATE, CLM_SERVO_EVENT and CLM_SERVO_COMMAND_ACK on a thread of
// its own, each message checked by telemetry::decode_checked before it is
// decoded (a datagram that fails is counted and dropped); publishes a
// servo::Command, the type the daemon executes, as telemetry::to_message
// maps it to servo_command_t, on CLM_SERVO_COMMAND for the axis and session a status
// names, as its client id, with a fresh sequence number, and waits for the
// ack with that axis, session, client and sequence; takes control before a
// command that needs it; waits for a status or for states; keeps the messages
// of a stretch of time. `clm ctl` and `clm commission --live` are built on it.
// Every command it sends carries the mac of the operators' key, and of what
// it receives it keeps only what carries that mac (telemetry/message_mac.hpp;
// docs/servod.md, "Who may command the axis"), and only statuses no older
// than kMaxStatusAge_s: a status, ack, state or event that another process
// makes up is counted (unauthenticated()) and changes nothing.
// Every failure throws servod_client::Error (a clm::RunTimeFailure: exit
// status 1 in the programs), one line.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "clm_lcm/servo_command_t.hpp"
#include "clm_lcm/servo_event_t.hpp"
#include "clm_lcm/servo_state_t.hpp"
#include "clm_lcm/servo_status_t.hpp"
#include "config/exit_status.hpp"
#include "config/sha256.hpp"
#include "daemon/servo/command.hpp"
#include "daemon/telemetry/telemetry.hpp"
#include "daemon/telemetry/wire_check.hpp"

namespace lcm {
class LCM;
struct ReceiveBuffer;
}  // namespace lcm

namespace clm::servod_client {

/// A duration for a message: "%g s".
std::string seconds(double value_s);

/// One LCM message as received: channel, receive time [µs since the UNIX epoch], bytes.
struct ReceivedMessage {
  std::string channel;
  std::int64_t utime = 0;
  std::vector<std::uint8_t> data;
};

/// Checks `data` against Message's layout (telemetry::decode_checked) and
/// decodes it into `out`; false for a message of other lcmtypes, damaged or
/// hostile (nothing is decoded then).
template <typename Message>
bool decode(const std::vector<std::uint8_t>& data, Message& out) {
  return telemetry::decode_checked(std::span<const std::uint8_t>(data.data(), data.size()), out).empty();
}

/// A command of kind `kind`: the servo::Command the daemon executes, the
/// fields of its kind to be set by the caller; send() sets utime, sequence,
/// axis, session and client and sends it as telemetry::to_message maps it.
servo::Command make_command(servo::CommandKind kind);
/// Copies `text` into a command's text field (a path, a parameter's name);
/// throws std::invalid_argument naming `what` (bad input) when it is longer
/// than the field holds.
template <std::size_t N>
void assign_text(servo::FixedText<N>& field, const std::string& text, const std::string& what) {
  if (!field.assign(text)) {
    throw std::invalid_argument(what + " is longer than " + std::to_string(N - 1) + " characters: '" + text + "'");
  }
}

/// True for the commands that need control: class kControlled in the
/// daemon's command table (servo::kCommandRoutes).
bool needs_control(servo::CommandKind kind);

/// This user's client id: FNV-1a-64 of "UID@HOSTNAME", as a positive int64,
/// never 0. The same in every process of the user on the host.
std::int64_t default_client_id();
/// The client id of `clm commission`: FNV-1a-64 of "commission:UID@HOSTNAME",
/// as default_client_id(); never that of `clm ctl`, so their leases do not mix.
std::int64_t commission_client_id();

/// How often a deadman lease is renewed (Client::start_deadman) [s]: a fifth
/// of the shortest commands.deadman_timeout_s the daemon accepts (0.5 s).
inline constexpr double kDeadmanRenewPeriod_s = 0.1;

/// The daemon a client commands: its axis and session (from its status).
struct Target {
  std::string axis;
  std::int64_t session = 0;
};

/// What the daemon answered on CLM_SERVO_COMMAND_ACK.
struct Ack {
  std::int64_t sequence = 0;
  std::string axis;
  std::int64_t session = 0;
  std::int64_t client = 0;
  bool accepted = false;
  std::string text;
};

/// Every failure of the client: LCM not opened, a publish refused, and the
/// subclasses below. All fail at run time: a program exits 1 on them
/// (config/exit_status.hpp).
class Error : public RunTimeFailure {
 public:
  using RunTimeFailure::RunTimeFailure;
};
/// Nothing (status, ack, states) came within the time waited.
class Timeout : public Error {
 public:
  using Error::Error;
};
/// No CLM_SERVO_COMMAND_ACK with the command's sequence within the timeout.
class NoAck : public Timeout {
 public:
  NoAck(const std::string& message, std::int64_t sequence) : Timeout(message), sequence_(sequence) {}
  std::int64_t sequence() const { return sequence_; }

 private:
  std::int64_t sequence_;
};
/// The daemon acknowledged the command with accepted = false (command()).
class Refused : public Error {
 public:
  Refused(const std::string& message, Ack ack) : Error(message), ack_(std::move(ack)) {}
  const Ack& ack() const { return ack_; }

 private:
  Ack ack_;
};
/// The daemon latched a fault (CLM_SERVO_STATE state FAULT) while waiting for states.
class Faulted : public Error {
 public:
  using Error::Error;
};
/// A SIGINT or SIGTERM came while waiting (stop_signals.hpp).
class Interrupted : public Error {
 public:
  using Error::Error;
};

/// $CLM_SERVO_LCM_URL when set and not empty, else `fallback`: the URL of a
/// tool that knows the daemon's configuration (clm commission --live).
std::string lcm_url_or(const std::string& fallback);

/// The LCM URL a client uses unless told otherwise (--lcm-url):
/// lcm_url_or(telemetry::kDefaultLcmUrl).
std::string default_lcm_url();

struct Options {
  std::string lcm_url = default_lcm_url();
  /// The channels to receive, an LCM regular expression: ".*" also receives
  /// events and the commands themselves (multicast loops them back).
  std::string channels = ".*";
  /// For every state of a run at 1 kHz on a loaded host: a 4 MiB socket
  /// receive buffer (telemetry::with_receive_buffer) and room for 60000
  /// queued messages (a minute of states). Off: LCM's defaults (30 messages).
  bool every_state = false;
  /// The client id the commands carry; 0: default_client_id().
  std::int64_t client_id = 0;
  /// The axis to command and report (servo_status_t.axis); empty: the only
  /// axis whose status is heard on the URL (target() refuses when several are).
  std::string axis;
  /// The operators' key file (config/command_key.hpp); empty:
  /// default_command_key_path(). Unreadable or unsafe: clm::FileError (exit 2).
  std::string key_file;
};

/// A status older than this by the wall clock is not kept: a replay of the
/// daemon's own signed status cannot show a state it left longer ago [s].
inline constexpr double kMaxStatusAge_s = 2.0;

/// Several daemons answer on the URL and Options::axis does not choose (target()).
class SeveralAxes : public Error {
 public:
  using Error::Error;
};

class Client {
 public:
  /// Opens LCM at options.lcm_url, subscribes and starts receiving. Throws
  /// Error when LCM cannot be opened.
  explicit Client(Options options);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  const std::string& lcm_url() const { return options_.lcm_url; }
  std::int64_t client_id() const { return client_id_; }

  /// The axis and session to command: on the first call, waits up to
  /// `timeout_s` [s] for a status of Options::axis (or of any axis; then,
  /// with `only_axis`, listens until that axis's next status, at most 1 s,
  /// for others), afterwards the same. Throws Timeout when no status comes,
  /// SeveralAxes (listing them) when several axes were heard, Options::axis
  /// is empty and `only_axis` is set. Without `only_axis`: the first axis heard.
  Target target(double timeout_s, bool only_axis = true);
  /// target(timeout_s), its timeout reported as NoAck for the command `what`.
  Target target_for(double timeout_s, const std::string& what);

  /// Publishes `command` on CLM_SERVO_COMMAND for target() (its axis and
  /// session), as client_id(), with a fresh sequence, the wall-clock utime
  /// and the operators' mac, and waits up to `timeout_s` [s] for the ack with that axis,
  /// session, client and sequence; returns it, accepted or not. A command
  /// that needs control (needs_control) is preceded by TAKE_CONTROL unless
  /// the latest status shows this client holding control with more than
  /// 1 s of lease left; a refused TAKE_CONTROL is returned as the ack.
  /// Throws Error when LCM refuses to publish, NoAck when no ack comes (or
  /// no status names the daemon to send to), SeveralAxes as target(). `what`
  /// names the command in those messages ("": named by its sequence alone).
  Ack send(servo::Command command, double timeout_s, const std::string& what = "");
  /// TAKE_CONTROL (always sent); Refused when the daemon refuses. `what`
  /// names the command control is taken for in a NoAck's message.
  void take_control(double timeout_s, const std::string& what = "TAKE_CONTROL");
  /// RELEASE_CONTROL; Refused when the daemon refuses.
  void release_control(double timeout_s);
  /// What a tool that ran something does when it ends early: STOP, then
  /// RELEASE_CONTROL (for a deadman lease the daemon then also ends an
  /// experiment). Refused or NoAck as command().
  void stop_and_release(double timeout_s);
  /// Makes control a deadman lease and keeps it: sends RENEW_CONTROL now and
  /// every kDeadmanRenewPeriod_s from a thread of its own (without waiting
  /// for acks), until stop_deadman(), the destructor, or a SIGINT/SIGTERM
  /// (stop_signals.hpp): then the renewals stop, and the daemon, once its
  /// deadman_timeout_s passes without any command of this client, stops the
  /// axis, ends an experiment and releases control, whatever this process is
  /// busy with. Take control first. Idempotent.
  void start_deadman();
  /// Stops the renewals (the daemon's deadman then runs out unless control is
  /// released or commands follow). Idempotent.
  void stop_deadman();
  /// True when the latest status of the target shows this client holding
  /// control with more than `margin_s` [s] of lease left.
  bool holds_control(double margin_s = 1.0) const;
  /// send(), and Refused ("clm-servod refused WHAT: TEXT") when the daemon
  /// refuses; returns the ack's text.
  std::string command(const std::string& what, servo::Command command, double timeout_s);

  /// Waits up to `timeout_s` [s] for a CLM_SERVO_STATUS newer than the last
  /// one this returned (on the first call: any received since connecting)
  /// and returns it. Throws Timeout when none comes.
  clm_lcm::servo_status_t wait_for_status(double timeout_s);
  /// Waits up to `timeout_s` [s] until the latest CLM_SERVO_STATE satisfies
  /// `done`. Throws Timeout naming `what`, or Faulted at once when the
  /// daemon latches a fault (its code and reason from the status).
  void wait_for_state(const std::string& what, double timeout_s,
                      const std::function<bool(const clm_lcm::servo_state_t&)>& done);
  /// Waits up to `timeout_s` [s] for `count` more CLM_SERVO_STATE messages.
  /// Throws Timeout naming `what`, Faulted when the latest state is a fault.
  void wait_states(std::int64_t count, double timeout_s, const std::string& what);

  std::optional<clm_lcm::servo_state_t> latest_state() const;
  /// The first CLM_SERVO_STATUS received since connecting, and the latest.
  std::optional<clm_lcm::servo_status_t> first_status() const;
  std::optional<clm_lcm::servo_status_t> latest_status() const;
  /// The latest CLM_SERVO_EVENT received.
  std::optional<clm_lcm::servo_event_t> latest_event() const;
  /// Messages on the daemon's channels that failed decode_checked.
  std::int64_t undecodable() const;
  /// Statuses, states, events and acks dropped for a mac not of the
  /// operators' key, and statuses older than kMaxStatusAge_s.
  std::int64_t unauthenticated() const;
  /// CLM_SERVO_STATE messages received (decoded) since connecting.
  std::int64_t states_received() const;

  /// From now on keeps every message received (the channels of Options).
  void start_capture();
  /// Stops keeping messages; returns those kept since start_capture().
  std::vector<ReceivedMessage> stop_capture();
  /// Returns the messages kept since start_capture() or the last call, and
  /// keeps capturing (a reader that runs as long as the daemon: clm scope).
  std::vector<ReceivedMessage> take_captured();

 private:
  void receive_loop();
  void on_message(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  std::int64_t fresh_sequence();
  /// Signs and publishes `command` for `to` as this client with a fresh
  /// sequence; returns the sequence. With `awaited`, its ack is kept for
  /// send_once. Throws Error when LCM refuses.
  std::int64_t publish(servo::Command& command, const Target& to, bool awaited, const std::string& what);
  void renew_loop();
  std::string fault_text() const;  ///< with mutex_ held
  /// Publishes `command` for `target` and waits for its ack (send() without
  /// taking control).
  Ack send_once(servo::Command command, const Target& target, double timeout_s, const std::string& what);
  /// True when `status` is of the axis this client reports (Options::axis,
  /// else the target once chosen, else any). With mutex_ held.
  bool reported(const clm_lcm::servo_status_t& status) const;

  struct AxisStatus {
    clm_lcm::servo_status_t status;
    std::int64_t received_utime = 0;  ///< [µs since the UNIX epoch]
    std::int64_t count = 0;           ///< statuses of the axis received
  };

  Options options_;
  std::int64_t client_id_ = 0;
  HmacSha256 key_;
  std::int64_t last_sequence_ = 0;
  std::unique_ptr<lcm::LCM> lcm_;
  std::thread receiver_;
  std::atomic<bool> stop_{false};
  std::thread renewer_;  ///< start_deadman's thread
  bool renewing_ = false;  ///< with mutex_ held
  std::mt19937_64 random_{std::random_device{}()};

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::set<std::int64_t> pending_;  ///< sequences sent whose ack has not come
  std::map<std::int64_t, Ack> acks_;
  std::optional<clm_lcm::servo_state_t> state_;
  std::optional<clm_lcm::servo_status_t> first_status_;
  std::optional<clm_lcm::servo_status_t> status_;
  std::optional<clm_lcm::servo_event_t> event_;
  std::map<std::string, AxisStatus> axes_;  ///< the latest status of each axis heard (at most 64 axes)
  std::optional<Target> target_;
  std::int64_t states_seen_ = 0;
  std::int64_t statuses_seen_ = 0;
  std::int64_t statuses_returned_ = 0;  ///< statuses_seen_ when wait_for_status last returned
  std::int64_t undecodable_ = 0;  ///< messages on the daemon's channels that failed decode_checked
  std::int64_t unauthenticated_ = 0;  ///< see unauthenticated()
  bool capturing_ = false;
  std::vector<ReceivedMessage> captured_;
};

}  // namespace clm::servod_client
