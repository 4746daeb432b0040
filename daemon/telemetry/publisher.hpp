#pragma once
// The publisher of clm-servod's telemetry and receiver of its commands
// (docs/telemetry.md).
//
// The real-time cycle hands fixed-size records and samples (no allocation)
// to a TelemetryPublisher through lock-free single-producer queues; the
// publisher's own thread converts them to the clm_lcm message types
// (lcm_conversion.hpp) and publishes them to its sinks: LCM (udpm
// multicast), an LCM log file, or memory. A full queue refuses the sample
// and counts the drop; the count goes out in the next status message.
// Commands arrive on a thread of their own (the receiver), never through
// liblcm: a UdpmReceiver (lcm_datagram.hpp) reads the group, each datagram's
// LCM header is checked before anything is sized from it (fragments are
// dropped unread and counted), commands are checked (wire_check.hpp's
// decode_checked, then to_command) and copied into fixed-size servo::Command
// structs. Stop, quick stop and disable go to the SafetyLatch when one is set
// (a flag the cycle reads, no queue), and are acked once a cycle has obeyed
// them; every other command reaches the daemon through the command queue.
// The receiver also listens to CLM_SERVO_STATUS for another daemon driving
// the same axis (foreign_session()).
//
// Thread roles: push_* — the real-time thread only (one producer per
// queue); poll_command — one consumer thread (the daemon's command thread).
// publish_ack, submit_command, counters — any non-real-time thread. Sinks
// are called from one thread at a time.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "clm_lcm/servo_command_t.hpp"
#include "config/sha256.hpp"
#include "daemon/servo/command.hpp"
#include "daemon/servo/cycle_record.hpp"
#include "daemon/telemetry/lcm_sink.hpp"
#include "daemon/telemetry/messages.hpp"
#include "daemon/telemetry/safety_refusals.hpp"
#include "daemon/telemetry/sink.hpp"
#include "daemon/telemetry/spsc_queue.hpp"

namespace lcm {
class LCM;
}  // namespace lcm

namespace clm::telemetry {

class UdpmReceiver;

/// Where the receiver hands stop, quick stop and disable
/// (servo::is_safety_command): daemon/servod's CommandServer, on the
/// daemon's safety latch (ServoDaemon::request_safety).
class SafetyLatch {
 public:
  virtual ~SafetyLatch() = default;
  /// Receiver thread; no allocation, no lock, no queue: latches `command`
  /// for the next cycle when the command authority admits it (it names this
  /// axis). Returns its ticket (> 0), or 0 when not admitted (the command
  /// then goes the ordinary way, to be refused with an ack).
  virtual std::uint64_t latch(const servo::Command& command) noexcept = 0;
  /// Any thread: the highest ticket a cycle has obeyed.
  virtual std::uint64_t obeyed() const noexcept = 0;
};

/// Settings of the publisher (the daemon's configuration fills them from
/// its `telemetry:` section, daemon/servod/servod_config.hpp).
struct TelemetryConfig {
  std::string lcm_url = kDefaultLcmUrl;
  /// The daemon's identity, stamped on every ack (config axis.name and the
  /// session id drawn at start-up).
  std::string axis = "axis0";
  std::int64_t session = 0;
  /// The operators' key (config/command_key.hpp): signs every message
  /// published and authenticates every command received but a stop, quick
  /// stop or disable (message_mac.hpp). Required with LCM; without it (a
  /// sink of its own, in-process commands) messages go out unsigned.
  std::optional<HmacSha256> key;
  /// Publish the state of cycles whose number is a multiple of this; 1 = every cycle.
  int state_decimation = 1;
  /// Queue capacities [items], powers of two. 4096 states = 4 s at 1 kHz.
  std::size_t state_queue_capacity = 4096;
  std::size_t status_queue_capacity = 16;
  std::size_t event_queue_capacity = 256;
  std::size_t command_queue_capacity = 64;
  std::size_t ack_queue_capacity = 64;
  /// How long the publisher thread sleeps (or waits for commands) when every
  /// queue is empty [s].
  double idle_period_s = 1e-3;
};

/// Totals since construction.
struct TelemetryCounters {
  std::int64_t states_pushed = 0;    ///< accepted by push_state (after decimation)
  std::int64_t states_dropped = 0;   ///< refused by push_state: queue full
  std::int64_t statuses_dropped = 0;
  std::int64_t events_dropped = 0;
  std::int64_t acks_dropped = 0;
  std::int64_t published = 0;         ///< messages handed to the sinks without error
  std::int64_t publish_failures = 0;  ///< sink errors (each sink counts once per message)
  std::int64_t commands_received = 0;
  std::int64_t commands_rejected = 0;  ///< undecodable, ill-formed, or the command queue was full
  /// Of commands_rejected: datagrams that failed decode_checked (not acked:
  /// nothing in them can be trusted) or to_command's field checks (acked).
  std::int64_t commands_malformed = 0;
  /// Of commands_rejected: commands other than stop, quick stop and disable
  /// whose mac is not the operators' (acked: the ack says so).
  std::int64_t commands_unauthenticated = 0;
  /// CLM_SERVO_STATUS messages of this axis from another session (another
  /// daemon driving the same axis on the same URL).
  std::int64_t foreign_statuses = 0;
  /// Datagrams dropped before any decode: LCM fragments (every message the
  /// daemon accepts fits one datagram, lcm_datagram.hpp) and datagrams
  /// without an LCM header.
  std::int64_t datagrams_dropped = 0;
  /// Stop, quick stop and disable handed to the SafetyLatch.
  std::int64_t safety_commands_latched = 0;
  std::int64_t telemetry_dropped() const { return states_dropped + statuses_dropped + events_dropped + acks_dropped; }
};

class TelemetryPublisher {
 public:
  /// Opens LCM on config.lcm_url to publish there, and a socket of its own
  /// on the same group and port to receive commands on CLM_SERVO_COMMAND
  /// (udpm URLs only). Throws std::invalid_argument for a bad config or URL
  /// and std::runtime_error when LCM or the socket cannot be opened.
  /// Allocates every queue and the receive buffer.
  explicit TelemetryPublisher(const TelemetryConfig& config);
  /// Publishes to `sink` only, no LCM; commands come in only through
  /// submit_command. `sink` must outlive the publisher.
  TelemetryPublisher(const TelemetryConfig& config, TelemetrySink& sink);
  /// stop().
  ~TelemetryPublisher();
  TelemetryPublisher(const TelemetryPublisher&) = delete;
  TelemetryPublisher& operator=(const TelemetryPublisher&) = delete;

  /// Also publishes everything to `sink` (e.g. an LcmLogWriter recording an
  /// experiment). Before start() only (std::logic_error otherwise).
  void add_sink(TelemetrySink& sink);
  /// Stop, quick stop and disable received from now on go to `latch`
  /// (which must outlive the publisher). Before start() only
  /// (std::logic_error otherwise).
  void set_safety_latch(SafetyLatch& latch);
  /// Starts the publisher thread (and the receiver's, with LCM).
  /// std::logic_error if it runs already.
  void start();
  /// Publishes what is still queued, then stops and joins the threads.
  void stop();

  // ---- real-time thread: never block, allocate or throw -------------------
  /// Queues `record` if its cycle is a multiple of state_decimation. False
  /// only when the queue was full (the drop is counted).
  bool push_state(const servo::CycleRecord& record) noexcept;
  /// False when the queue was full (counted).
  bool push_status(const ServoStatusSample& sample) noexcept;
  bool push_event(const ServoEventSample& sample) noexcept;
  bool push_ack(const ServoCommandAck& ack) noexcept;
  /// The oldest well-formed command not yet taken; false if none.
  bool poll_command(servo::Command& out) noexcept;

  // ---- any other thread ---------------------------------------------------
  /// Publishes an ack now, on the calling thread.
  void publish_ack(std::int64_t sequence, std::int64_t client, bool accepted, std::string_view text);
  /// Publishes an event now, on the calling thread (not the real-time one).
  void publish_event(const ServoEventSample& sample);
  /// The session of the last CLM_SERVO_STATUS of this axis from another
  /// session (0: none seen), with the LCM instance only.
  std::int64_t foreign_session() const noexcept { return foreign_session_.load(std::memory_order_acquire); }
  /// The refusals of stop, quick stop and disable, for the journal: this
  /// publisher records those it refuses (ill-formed, queue full), the command
  /// server those it and the daemon refuse; the daemon's monitor logs them.
  SafetyRefusalLog& safety_refusals() noexcept { return safety_refusals_; }
  /// Handles `message` as if it had arrived on CLM_SERVO_COMMAND: checks it,
  /// latches it (a safety command, with a SafetyLatch set: acked once a
  /// cycle obeyed it, on the receiver thread or at the next
  /// flush_safety_acks), queues it for poll_command, or refuses it with an
  /// ack. True if latched or queued.
  bool submit_command(const clm_lcm::servo_command_t& message);
  /// Acks the latched safety commands a cycle has obeyed; the receiver
  /// thread calls it after every datagram and every 1 ms while any waits.
  void flush_safety_acks();
  /// The longest LCM payload the daemon accepts on any channel it reads [bytes].
  static std::size_t max_accepted_payload_bytes() noexcept;
  TelemetryCounters counters() const noexcept;
  const TelemetryConfig& config() const { return config_; }

 private:
  /// A latched safety command waiting for a cycle to obey it.
  struct PendingSafetyAck {
    std::int64_t sequence = 0;
    std::int64_t client = 0;
    std::uint64_t ticket = 0;
  };

  void run();
  void receive();
  void on_datagram(std::span<const std::uint8_t> datagram);
  std::size_t drain();
  template <typename Message>
  void publish_to_sinks(const char* channel, const Message& message, std::int64_t utime);
  void on_command(std::span<const std::uint8_t> payload);
  void on_status(std::span<const std::uint8_t> payload);
  void ack_safety(const PendingSafetyAck& pending);

  TelemetryConfig config_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::unique_ptr<LcmSink> lcm_sink_;
  std::unique_ptr<UdpmReceiver> receiver_;
  std::vector<std::uint8_t> datagram_;  // the receiver's buffer, one UDP datagram
  SafetyLatch* safety_latch_ = nullptr;
  SafetyRefusalLog safety_refusals_;
  /// Latched safety commands not yet acked, oldest first. Only safety
  /// commands fill it; full, the oldest is acked at once (latched, it is
  /// obeyed without condition by the next cycle).
  std::array<PendingSafetyAck, 64> pending_safety_{};
  std::size_t pending_safety_count_ = 0;
  std::mutex safety_mutex_;  // guards pending_safety_ (the receiver; in-process submit_command callers)
  std::vector<TelemetrySink*> sinks_;
  std::mutex sink_mutex_;     // serialises sink calls (publisher thread, publish_ack)
  std::mutex command_mutex_;  // serialises producers of the command queue (LCM handler, submit_command)

  SpscQueue<servo::CycleRecord> states_;
  SpscQueue<ServoStatusSample> statuses_;
  SpscQueue<ServoEventSample> events_;
  SpscQueue<ServoCommandAck> acks_;
  SpscQueue<servo::Command> commands_;

  // Written by the real-time thread, read by anyone.
  std::atomic<std::int64_t> states_pushed_{0};
  std::atomic<std::int64_t> states_dropped_{0};
  std::atomic<std::int64_t> statuses_dropped_{0};
  std::atomic<std::int64_t> events_dropped_{0};
  std::atomic<std::int64_t> acks_dropped_{0};
  // Written by the publisher thread (and publish_ack / submit_command).
  std::atomic<std::int64_t> published_{0};
  std::atomic<std::int64_t> publish_failures_{0};
  std::atomic<std::int64_t> commands_received_{0};
  std::atomic<std::int64_t> commands_rejected_{0};
  std::atomic<std::int64_t> commands_malformed_{0};
  std::atomic<std::int64_t> commands_unauthenticated_{0};
  std::atomic<std::int64_t> foreign_statuses_{0};
  std::atomic<std::int64_t> foreign_session_{0};
  std::atomic<std::int64_t> datagrams_dropped_{0};
  std::atomic<std::int64_t> safety_latched_{0};

  std::atomic<bool> stop_requested_{false};
  std::thread thread_;
  std::thread receiver_thread_;
};

}  // namespace clm::telemetry
