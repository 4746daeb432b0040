#pragma once
// The commissioning's runs on a separately running clm-servod, over LCM
// (docs/servod.md "Commands", docs/telemetry.md), through the
// servod_client: control of the axis is taken before the first command and
// released at the end (docs/servod.md "Command authority"); every command goes out on CLM_SERVO_COMMAND and waits for
// the CLM_SERVO_COMMAND_ACK with its sequence; files (programs, calibration, models, feedforward) are sent as
// absolute paths, which the daemon opens itself; the cycles come back as
// CLM_SERVO_STATE. A run is checked for missing states by the state's cycle
// counter: any gap is reported, and the run is repeated (LiveOptions::
// attempts_per_run) or commissioning fails.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "daemon/servo/command.hpp"
#include "daemon/servod/servod_config.hpp"
#include "tools/commission/preflight.hpp"
#include "tools/commission/runner.hpp"
#include "tools/commission/runs.hpp"
#include "tools/servod_client/client.hpp"

namespace clm::telemetry {
class LcmLogWriter;
}

namespace clm::commission {

using servod_client::ReceivedMessage;

/// Cycles missing from a sequence of CLM_SERVO_STATE cycle counters that
/// should follow one another (each = previous + 1): the number missing and
/// the gaps as "a..b" ranges (at most `max_ranges` listed), as
/// lcmlog::find_cycle_gaps and lcmlog::describe_ranges find them for logs. Pure: no I/O.
struct StateGaps {
  std::int64_t missing = 0;
  std::int64_t out_of_order = 0;  ///< a counter not above its predecessor
  std::int64_t force_unmeasured = 0;  ///< states of the running program without a force-sensor frame
  std::string ranges;
};
StateGaps find_state_gaps(const std::vector<std::int64_t>& cycles, int max_ranges = 5);

class LcmRunner final : public ExperimentRunner {
 public:
  /// Opens LCM at options.lcm_url and starts receiving. `config` is the
  /// daemon's configuration (motor, soft limits, period). Throws when an
  /// option is out of range or LCM cannot be opened.
  LcmRunner(const servod::ServodConfig& config, LiveOptions options);
  /// Releases control of the axis if enable() took it (a failure is a warning on stderr).
  ~LcmRunner() override;
  LcmRunner(const LcmRunner&) = delete;
  LcmRunner& operator=(const LcmRunner&) = delete;

  /// What the daemon shows before anything is commanded, for the checks of
  /// live_preflight: its latest status (waiting up to the ack timeout for
  /// one; none is a NoAck naming ENABLE, the first command) and a
  /// CLM_SERVO_STATE (waiting up to 1 s more; none: no state in the view).
  DaemonView observe();
  /// TAKE_CONTROL (held for the whole commissioning), ENABLE; then checks that states arrive for every cycle, at the
  /// configuration's period and coil-set count.
  void enable() override;
  void set_experiment(int coil_set, double delta_rad) override;
  /// Asks the operator on stderr to mount (or remove) the payload with the
  /// axis disabled, then reads a line from stdin; end of input refuses.
  void set_payload(double payload_kg) override;
  void set_commutation(servo::CommutationMode mode) override;
  void load_calibration(const std::string& path) override;
  void load_model(servo::CommutationMode mode, const std::string& path) override;
  void load_feedforward(const control::FeedforwardParameters& parameters, const std::string& path) override;
  void open_log(const std::string& path) override;
  void close_log() override;
  Recording run_program(const servod::ProgramFile& program, const std::string& program_path,
                        const std::string& name, Disturbance disturbance) override;
  const sim::SimulatedMotor* simulated_motor() const override { return nullptr; }
  std::string oracle_unavailable_reason() const override;
  LiveSummary live_summary() const override;
  std::vector<std::string> notes() const override;

 private:
  /// ENABLE, and the state of the enabled axis back within 2 s.
  void enable_axis();
  /// Publishes a command and waits for its ack; throws on a timeout or a
  /// refusal, naming `what`.
  std::string command(const std::string& what, servo::Command message);
  /// Waits for `cycles` more states.
  void wait_cycles(std::int64_t cycles, const std::string& what);
  /// One attempt of a run; the recording, the messages and the gaps.
  Recording attempt(const servod::ProgramFile& program, const std::string& program_path, const std::string& name,
                    std::vector<ReceivedMessage>& messages, StateGaps& gaps, std::int64_t& states);

  servod::ServodConfig config_;
  LiveOptions options_;
  servod_client::Client client_;

  std::unique_ptr<telemetry::LcmLogWriter> log_;
  LiveSummary summary_;
  std::vector<std::string> notes_;
  bool took_control_ = false;
};

}  // namespace clm::commission
