#pragma once
// Telemetry and commands of clm-servod over LCM (docs/telemetry.md).
//
// The real-time cycle fills fixed-size samples (no allocation) and hands them
// to a TelemetryPublisher through lock-free single-producer queues; the
// publisher's own thread converts them to the clm_lcm message types and
// publishes them to its sinks: LCM (udpm multicast), an LCM log file, or
// memory. A full queue refuses the sample and counts the drop; the count goes
// out in the next status message. Commands arrive on the same LCM instance,
// are checked and copied into fixed-size ServoCommand structs, and reach the
// cycle through another queue.
//
// Thread roles: push_*, poll_command — the real-time thread only (one
// producer per queue, one consumer). publish_ack, submit_command, counters —
// any non-real-time thread. Sinks are called from one thread at a time.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "clm_lcm/servo_command_ack_t.hpp"
#include "clm_lcm/servo_command_t.hpp"
#include "clm_lcm/servo_event_t.hpp"
#include "clm_lcm/servo_state_t.hpp"
#include "clm_lcm/servo_status_t.hpp"
#include "commutation/types.hpp"
#include "daemon/telemetry/spsc_queue.hpp"

namespace lcm {
class LCM;
class LogFile;
struct ReceiveBuffer;
}  // namespace lcm

namespace clm::yaml {
class Node;
}

namespace clm::telemetry {

/// LCM channels of clm-servod.
inline constexpr const char* kStateChannel = "CLM_SERVO_STATE";
inline constexpr const char* kStatusChannel = "CLM_SERVO_STATUS";
inline constexpr const char* kEventChannel = "CLM_SERVO_EVENT";
inline constexpr const char* kCommandChannel = "CLM_SERVO_COMMAND";
inline constexpr const char* kCommandAckChannel = "CLM_SERVO_COMMAND_ACK";

/// Multicast on the local host only (ttl=0): LCM's default group and port.
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

/// `url` with a 4 MiB kernel receive buffer asked for (LCM's udpm option
/// recv_buf_size, capped by net.core.rmem_max) when it is udpm and does not
/// set one. Every udpm receiver on the port also receives the daemon's
/// states (about 1 KiB of socket buffer each, datagram overhead included);
/// the default 208 KiB then holds some 200 ms of them, and a receiver
/// descheduled longer on a loaded host lost states, and commands with them.
std::string with_receive_buffer(const std::string& url);

/// Text in a fixed char array, always NUL-terminated: what the cycle can
/// fill without allocating.
template <std::size_t N>
struct FixedText {
  static_assert(N >= 2);
  static constexpr std::size_t kMaxChars = N - 1;

  std::array<char, N> chars{};

  /// Copies `text`. False if it is longer than kMaxChars; then the first
  /// kMaxChars characters are kept (callers that must not cut, refuse).
  bool assign(std::string_view text) noexcept {
    const std::size_t count = text.size() < kMaxChars ? text.size() : kMaxChars;
    for (std::size_t i = 0; i < count; ++i) chars[i] = text[i];
    chars[count] = '\0';
    return count == text.size();
  }
  std::string_view view() const noexcept { return std::string_view(chars.data()); }
  bool empty() const noexcept { return chars[0] == '\0'; }
};

/// One-line reasons and event texts: up to 127 characters.
using ReasonText = FixedText<128>;
/// File paths in commands and status: up to 255 characters.
using PathText = FixedText<256>;

/// One cycle, as servo_state_t (lcmtypes/servo_state_t.lcm documents every
/// field; the names are the same). Filled by the cycle.
struct ServoStateSample {
  std::int64_t utime = 0;  ///< wall-clock time [µs since the UNIX epoch]; 0 = stamp at publication
  std::int64_t cycle = 0;
  double t_s = 0.0;
  double r_m = 0.0;
  double r_dot_m_per_s = 0.0;
  double r_ddot_m_per_s2 = 0.0;
  double y_m = 0.0;
  double e_m = 0.0;
  double F_star_N = 0.0;
  double u_fb_N = 0.0;
  double u_ff_N = 0.0;
  double Fy_star_N = 0.0;
  double Fx_star_N = 0.0;
  double Tz_star_Nm = 0.0;
  double Fy_N = 0.0;
  double Fx_N = 0.0;
  double Tz_Nm = 0.0;
  std::int8_t commutation = 0;  ///< clm_lcm::servo_state_t::COMMUTATION_*
  std::int8_t coil_set = 0;     ///< experiment coil set 1..coil_sets, 0 = none
  double delta_rad = 0.0;       ///< experiment phase offset [rad]
  std::int8_t coil_sets = 0;    ///< L, 0..kMaxCoilSets; the arrays' first L entries are sent
  std::array<double, kMaxCoilSets> magnitude_N{};
  std::array<double, kMaxCoilSets> setpoint_delta_rad{};
  std::array<double, kMaxCoilSets> ia_A{};
  std::array<double, kMaxCoilSets> ib_A{};
  bool damping_engaged = false;
  double current_square_sum_A2 = 0.0;
  bool force_limited = false;
  std::int8_t state = 0;        ///< clm_lcm::servo_status_t::STATE_*
  bool program_running = false;
  double program_time_s = 0.0;  ///< [s]
};

/// Daemon health, as servo_status_t, without telemetry_dropped (the
/// publisher fills that in from its own counters).
struct ServoStatusSample {
  std::int64_t utime = 0;  ///< [µs since the UNIX epoch]; 0 = stamp at publication
  std::int8_t state = 0;   ///< clm_lcm::servo_status_t::STATE_*
  std::int16_t fault = 0;  ///< daemon/servo/fault.hpp code, 0 = none
  ReasonText fault_reason;
  std::int64_t fault_cycle = -1;  ///< -1 = no fault
  std::int8_t commutation = 0;
  PathText model_file;
  PathText calibration_file;
  double wakeup_latency_p50_s = 0.0;
  double wakeup_latency_p99_s = 0.0;
  double wakeup_latency_max_s = 0.0;
  double compute_time_p50_s = 0.0;
  double compute_time_p99_s = 0.0;
  double compute_time_max_s = 0.0;
  std::int64_t overruns = 0;
  std::int64_t cycles = 0;
  std::int64_t frames_sent = 0;
  std::int64_t frames_received = 0;
  std::int64_t frames_missing = 0;
  std::int64_t frames_late = 0;
  std::int64_t frames_rejected = 0;
  std::int8_t bus_state = -1;  ///< clm_lcm::servo_status_t::BUS_STATE_*
  std::int64_t damping_cycles = 0;
  bool program_running = false;
  double program_time_s = 0.0;
};

/// Something that happened once, as servo_event_t.
struct ServoEventSample {
  std::int64_t utime = 0;  ///< [µs since the UNIX epoch]; 0 = stamp at publication
  std::int64_t cycle = 0;
  std::int16_t code = 0;
  std::int8_t severity = 0;  ///< clm_lcm::servo_event_t::SEVERITY_*
  ReasonText text;
};

/// servo_command_t.command.
enum class CommandKind : std::int8_t {
  kEnable = 1,
  kDisable = 2,
  kClearFault = 3,
  kMoveTo = 4,
  kRunProgram = 5,
  kSetCommutation = 6,
  kSetExperiment = 7,
  kLoadCalibration = 8,
  kLoadModel = 9,
  kStop = 10,
  kLoadFeedforward = 11,
};

/// A checked command for the cycle: only the fields of `command` are meaningful.
struct ServoCommand {
  std::int64_t utime = 0;
  std::int64_t sequence = 0;
  CommandKind command = CommandKind::kStop;
  double target_m = 0.0;               ///< kMoveTo [m]
  double velocity_m_per_s = 0.0;       ///< kMoveTo [m/s]
  double acceleration_m_per_s2 = 0.0;  ///< kMoveTo [m/s²]
  double jerk_m_per_s3 = 0.0;          ///< kMoveTo [m/s³]
  PathText program;                    ///< kRunProgram
  std::int8_t commutation = 0;         ///< kSetCommutation: servo_state_t::COMMUTATION_*
  std::int8_t coil_set = 0;            ///< kSetExperiment: 1..kMaxCoilSets (the cycle checks against L)
  double delta_rad = 0.0;              ///< kSetExperiment [rad]
  PathText path;                       ///< kLoadCalibration, kLoadModel, kLoadFeedforward
};

/// The cycle's answer to a command, as servo_command_ack_t.
struct ServoCommandAck {
  std::int64_t utime = 0;  ///< 0 = stamp at publication
  std::int64_t sequence = 0;
  bool accepted = false;
  ReasonText text;
};

/// Wall-clock time [µs since the UNIX epoch], the LCM convention for utime.
std::int64_t wall_clock_utime() noexcept;

// Conversions to the LCM types. Off the real-time thread only: they allocate.
// A sample's utime of 0 becomes wall_clock_utime().
clm_lcm::servo_state_t to_message(const ServoStateSample& sample);
clm_lcm::servo_status_t to_message(const ServoStatusSample& sample, std::int64_t telemetry_dropped);
clm_lcm::servo_event_t to_message(const ServoEventSample& sample);
clm_lcm::servo_command_ack_t to_message(const ServoCommandAck& ack);

/// Checks a received command and copies it into `out`. Returns "" when it is
/// well-formed, else the one-line reason to send back in the ack: unknown
/// command, a non-finite number, an unknown commutation mode, a coil set
/// outside 1..kMaxCoilSets, an empty or too long (> 255 characters) path.
/// Limits that depend on the motor (stroke, L) are the daemon's to check.
std::string to_command(const clm_lcm::servo_command_t& message, ServoCommand& out);

/// Where telemetry goes: LCM, an LCM log, memory (drake's pattern: LCM behind
/// an interface with a log implementation, so tests need no network).
class TelemetrySink {
 public:
  virtual ~TelemetrySink() = default;
  /// One encoded message on `channel`, stamped `utime` [µs since the UNIX
  /// epoch]. May throw std::runtime_error; the publisher counts the failure.
  virtual void publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) = 0;
};

/// Encodes `message` (a clm_lcm type) and publishes it on `sink`.
template <typename Message>
void publish_message(TelemetrySink& sink, std::string_view channel, const Message& message, std::int64_t utime) {
  std::vector<std::uint8_t> buffer(static_cast<std::size_t>(message.getEncodedSize()));
  message.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
  sink.publish(channel, buffer, utime);
}

/// Publishes on an LCM instance the caller owns.
class LcmSink : public TelemetrySink {
 public:
  explicit LcmSink(lcm::LCM& lcm) : lcm_(lcm) {}
  /// Throws std::runtime_error when LCM refuses the message (e.g. no route
  /// for the multicast group).
  void publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) override;

 private:
  lcm::LCM& lcm_;
};

/// Writes every message as an event of an LCM log (readable by lcm-logplayer,
/// lcm-spy's log player and tools/lcmlog). Writes `path`.tmp and renames it
/// to `path` in close(), so a crash or an error never leaves a partial log
/// under the final name.
class LcmLogWriter : public TelemetrySink {
 public:
  /// Opens `path`.tmp; throws std::runtime_error naming it.
  explicit LcmLogWriter(std::string path);
  /// Without a successful close() the log stays under `path`.tmp, as a crash
  /// would leave it.
  ~LcmLogWriter() override;
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;

  /// Throws std::runtime_error naming the file and the event on a write
  /// error; the log is then never renamed into place.
  void publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) override;
  /// Flushes and fsyncs `path`.tmp and renames it to `path`. Throws
  /// std::runtime_error after any write error (the .tmp stays). Idempotent.
  void close();

  const std::string& path() const { return path_; }
  std::int64_t events_written() const { return events_written_; }

 private:
  std::string path_;
  std::string temporary_path_;
  std::unique_ptr<lcm::LogFile> log_;
  std::int64_t events_written_ = 0;
  std::string error_;
  bool closed_ = false;
};

/// Keeps every message in memory (tests, simulation). Thread-safe.
class MemorySink : public TelemetrySink {
 public:
  struct Event {
    std::string channel;
    std::int64_t utime = 0;
    std::vector<std::uint8_t> data;
  };

  void publish(std::string_view channel, std::span<const std::uint8_t> data, std::int64_t utime) override;
  std::vector<Event> events() const;
  std::size_t size() const;

  /// Every message on `channel`, decoded as `Message`; throws
  /// std::runtime_error naming the event when one does not decode.
  template <typename Message>
  std::vector<Message> decode(std::string_view channel) const {
    std::vector<Message> result;
    const auto all = events();
    for (std::size_t i = 0; i < all.size(); ++i) {
      if (all[i].channel != channel) continue;
      Message message;
      const int size = static_cast<int>(all[i].data.size());
      if (message.decode(all[i].data.data(), 0, size) != size) {
        throw std::runtime_error("memory sink: event " + std::to_string(i) + ": cannot decode " + std::string(channel));
      }
      result.push_back(std::move(message));
    }
    return result;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<Event> events_;
};

/// Settings of the publisher; YAML section `telemetry:` (read_telemetry_config).
struct TelemetryConfig {
  std::string lcm_url = kDefaultLcmUrl;
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

/// Reads the map under `telemetry:`; every key optional, unknown keys and bad
/// values are errors (clm::yaml::Error with file, line, key).
TelemetryConfig read_telemetry_config(const yaml::Node& section);

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
  std::int64_t telemetry_dropped() const { return states_dropped + statuses_dropped + events_dropped + acks_dropped; }
};

class TelemetryPublisher {
 public:
  /// Opens LCM on config.lcm_url, publishes there and receives commands on
  /// CLM_SERVO_COMMAND. Throws std::invalid_argument for a bad config and
  /// std::runtime_error when LCM cannot be opened. Allocates every queue.
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
  /// Starts the publisher thread. std::logic_error if it runs already.
  void start();
  /// Publishes what is still queued, then stops and joins the thread.
  void stop();

  // ---- real-time thread: never block, allocate or throw -------------------
  /// Queues `sample` if its cycle is a multiple of state_decimation. False
  /// only when the queue was full (the drop is counted).
  bool push_state(const ServoStateSample& sample) noexcept;
  /// False when the queue was full (counted).
  bool push_status(const ServoStatusSample& sample) noexcept;
  bool push_event(const ServoEventSample& sample) noexcept;
  bool push_ack(const ServoCommandAck& ack) noexcept;
  /// The oldest well-formed command not yet taken; false if none.
  bool poll_command(ServoCommand& out) noexcept;

  // ---- any other thread ---------------------------------------------------
  /// Publishes an ack now, on the calling thread.
  void publish_ack(std::int64_t sequence, bool accepted, std::string_view text);
  /// Handles `message` as if it had arrived on CLM_SERVO_COMMAND: checks it,
  /// queues it for poll_command, or refuses it with an ack. True if queued.
  bool submit_command(const clm_lcm::servo_command_t& message);
  TelemetryCounters counters() const noexcept;
  const TelemetryConfig& config() const { return config_; }

 private:
  void run();
  std::size_t drain();
  template <typename Message>
  void publish_to_sinks(const char* channel, const Message& message, std::int64_t utime);
  void on_command(const lcm::ReceiveBuffer* buffer, const std::string& channel);

  TelemetryConfig config_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::unique_ptr<LcmSink> lcm_sink_;
  std::vector<TelemetrySink*> sinks_;
  std::mutex sink_mutex_;     // serialises sink calls (publisher thread, publish_ack)
  std::mutex command_mutex_;  // serialises producers of the command queue (LCM handler, submit_command)

  SpscQueue<ServoStateSample> states_;
  SpscQueue<ServoStatusSample> statuses_;
  SpscQueue<ServoEventSample> events_;
  SpscQueue<ServoCommandAck> acks_;
  SpscQueue<ServoCommand> commands_;

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

  std::atomic<bool> stop_requested_{false};
  std::thread thread_;
};

}  // namespace clm::telemetry
