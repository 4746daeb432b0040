#pragma once
// The commissioning's runs on a separately running clm-servod, over LCM
// (docs/servod.md "Commands", docs/telemetry.md): every command goes out on
// CLM_SERVO_COMMAND and waits for the CLM_SERVO_COMMAND_ACK with its
// sequence; files (programs, calibration, models, feedforward) are sent as
// absolute paths, which the daemon opens itself; the cycles come back as
// CLM_SERVO_STATE. A run is checked for missing states by the state's cycle
// counter: any gap is reported, and the run is repeated (LiveOptions::
// attempts_per_run) or commissioning fails.

#include <atomic>
#include <condition_variable>
#include <functional>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "clm_lcm/servo_command_t.hpp"
#include "clm_lcm/servo_state_t.hpp"
#include "clm_lcm/servo_status_t.hpp"
#include "daemon/servod/servod_config.hpp"
#include "tools/commission/runner.hpp"
#include "tools/commission/runs.hpp"

namespace lcm {
class LCM;
struct ReceiveBuffer;
}  // namespace lcm

namespace clm::telemetry {
class LcmLogWriter;
}

namespace clm::commission {

/// One LCM message as received: channel, receive time [µs since the UNIX epoch], bytes.
struct ReceivedMessage {
  std::string channel;
  std::int64_t utime = 0;
  std::vector<std::uint8_t> data;
};

/// Cycles missing from a sequence of CLM_SERVO_STATE cycle counters that
/// should follow one another (each = previous + 1): the number missing and
/// the gaps as "a..b" ranges (at most `max_ranges` listed). Pure: no I/O.
struct StateGaps {
  std::int64_t missing = 0;
  std::int64_t out_of_order = 0;  ///< a counter not above its predecessor
  std::string ranges;
};
StateGaps find_state_gaps(const std::vector<std::int64_t>& cycles, int max_ranges = 5);

class LcmRunner final : public ExperimentRunner {
 public:
  /// Opens LCM at options.lcm_url and starts receiving. `config` is the
  /// daemon's configuration (motor, soft limits, period). Throws when LCM
  /// cannot be opened.
  LcmRunner(const servod::ServodConfig& config, LiveOptions options);
  ~LcmRunner() override;
  LcmRunner(const LcmRunner&) = delete;
  LcmRunner& operator=(const LcmRunner&) = delete;

  /// ENABLE; then checks that states arrive for every cycle, at the
  /// configuration's period and coil-set count.
  void enable() override;
  void set_experiment(int coil_set, double delta_rad) override;
  void set_commutation(servo::CommutationMode mode) override;
  void load_calibration(const std::string& path) override;
  void load_model(servo::CommutationMode mode, const std::string& path) override;
  void load_feedforward(const control::FeedforwardParameters& parameters, const std::string& path) override;
  void open_log(const std::string& path) override;
  void close_log() override;
  Recording run_program(const servod::ProgramFile& program, const std::string& program_path,
                        const std::string& name) override;
  const sim::SimulatedMotor* simulated_motor() const override { return nullptr; }
  std::string oracle_unavailable_reason() const override;
  LiveSummary live_summary() const override;
  std::vector<std::string> notes() const override;

 private:
  struct Ack {
    bool accepted = false;
    std::string text;
  };
  void receive_loop();
  void on_message(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  /// Publishes a command with a fresh sequence and waits for its ack; throws
  /// on a timeout or a refusal, naming `what`.
  std::string command(const std::string& what, clm_lcm::servo_command_t message);
  /// Waits until the latest state satisfies `done` (or `timeout_s` passes:
  /// throws naming `what`); a latched fault throws at once.
  void wait_for_state(const std::string& what, double timeout_s,
                      const std::function<bool(const clm_lcm::servo_state_t&)>& done);
  /// Waits for `cycles` more states.
  void wait_cycles(std::int64_t cycles, const std::string& what);
  std::string fault_text() const;  ///< with mutex_ held
  /// One attempt of a run; the recording, the messages and the gaps.
  Recording attempt(const servod::ProgramFile& program, const std::string& program_path, const std::string& name,
                    std::vector<ReceivedMessage>& messages, StateGaps& gaps, std::int64_t& states);

  servod::ServodConfig config_;
  LiveOptions options_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::thread receiver_;
  std::atomic<bool> stop_{false};

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::int64_t, Ack> acks_;
  std::optional<clm_lcm::servo_state_t> state_;
  std::optional<clm_lcm::servo_status_t> status_;
  std::int64_t states_seen_ = 0;
  std::int64_t undecodable_ = 0;  ///< messages on our channels that did not decode (another version's types)
  bool capturing_ = false;
  std::vector<ReceivedMessage> captured_;

  std::unique_ptr<telemetry::LcmLogWriter> log_;
  std::optional<std::int64_t> first_dropped_;
  LiveSummary summary_;
  std::vector<std::string> notes_;
};

}  // namespace clm::commission
