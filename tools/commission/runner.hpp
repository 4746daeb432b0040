#pragma once
// Where the commissioning's runs happen. The pipeline (commission.cpp) drives
// an ExperimentRunner and does every offline step itself, so the simulated
// and the live commissioning share all numerical code:
//  - InProcessRunner (runs.hpp): a daemon core in this process with the
//    configuration's embedded simulated motor, on a virtual clock;
//  - LcmRunner (live_runner.hpp): a separately running clm-servod, over LCM.
// Every method throws std::runtime_error with one line saying what failed.

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "daemon/control/position_controller.hpp"
#include "daemon/servo/servo_cycle.hpp"
#include "daemon/servod/program_file.hpp"
#include "tools/servod_client/client.hpp"

namespace clm::sim {
class SimulatedMotor;
struct ErrorSources;
}

namespace clm::commission {

struct Recording;  // runs.hpp

/// How to reach a running clm-servod (LcmRunner).
struct LiveOptions {
  /// Empty: $CLM_SERVO_LCM_URL, else the configuration's telemetry.lcm_url.
  std::string lcm_url;
  /// The operators' key shared with the daemon; empty: clm::default_command_key_path().
  std::string key_file;
  /// How long each command waits for its CLM_SERVO_COMMAND_ACK [s].
  double ack_timeout_s = 2.0;
  /// A run in which CLM_SERVO_STATE messages went missing is run again, up
  /// to this many attempts in all; then commissioning fails.
  int attempts_per_run = 3;
};

/// What a live commissioning received (report.json "live").
struct LiveSummary {
  bool live = false;
  std::string lcm_url;
  std::int64_t states_received = 0;     ///< CLM_SERVO_STATE messages of every attempt of every run
  std::int64_t states_recorded = 0;     ///< program cycles kept in the runs evaluated
  std::int64_t states_missing_kept = 0; ///< cycles missing in the runs kept (always 0: a gap repeats the run)
  std::int64_t states_missing_discarded = 0;  ///< cycles missing in attempts that were repeated
  int runs = 0;
  int runs_repeated = 0;
  std::int64_t daemon_telemetry_dropped = 0;  ///< servo_status_t.telemetry_dropped growth during commissioning
};

/// The daemon refused a law's file (its gains or cost out of bounds, docs/
/// servod.md "What a law may cost and mean"): that law is reported as not
/// evaluated, with the daemon's reason, and commissioning goes on.
class LawRefused : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What a simulated motor's force disturbance does at a run's start.
enum class Disturbance {
  kRunsOn,    ///< it goes on as it was: each run meets another stretch of it
  /// It starts again at the program's start, so that the runs comparing laws
  /// meet the same one. A real axis's floor does not restart: live, as kRunsOn.
  kRestarts,
};

class ExperimentRunner {
 public:
  virtual ~ExperimentRunner() = default;
  /// Closes the loop at the present position.
  virtual void enable() = 0;
  /// Experiment mode: coil set `coil_set` (1-based) alone, phase offset `delta_rad` [rad].
  virtual void set_experiment(int coil_set, double delta_rad) = 0;
  /// The payload mounted on the translator from now on [kg] (0: none), for
  /// the experiments that give the mass without a force sensor
  /// (docs/commissioning.md, "The force scale from a known payload"): in
  /// process the simulated motor's; live the operator mounts or removes it
  /// when asked and confirms. Throws std::runtime_error when it cannot be
  /// done (live: no confirmation).
  virtual void set_payload(double payload_kg) = 0;
  /// Switches the commutation law; returns once the law is in use.
  virtual void set_commutation(servo::CommutationMode mode) = 0;
  /// Loads a calibration file (absolute path) into the classical law; returns once it is in use.
  virtual void load_calibration(const std::string& path) = 0;
  /// Loads a model file (absolute path) into the pgnn or spline law; returns once it is in use.
  /// Both throw LawRefused when the daemon refuses the file.
  virtual void load_model(servo::CommutationMode mode, const std::string& path) = 0;
  /// Sets the feedforward of eq. (40): `parameters`, which the file at `path`
  /// (absolute, format clm-servo-feedforward) holds.
  virtual void load_feedforward(const control::FeedforwardParameters& parameters, const std::string& path) = 0;
  /// The runs after this go into the LCM log at `path` (until close_log).
  virtual void open_log(const std::string& path) = 0;
  /// Closes the log (temporary file renamed into place).
  virtual void close_log() = 0;
  /// Moves to the program's start, settles, runs `program` (whose file is
  /// `program_path`, absolute) and returns the cycles of the program proper.
  virtual Recording run_program(const servod::ProgramFile& program, const std::string& program_path,
                                const std::string& name, Disturbance disturbance) = 0;
  /// The simulator's truth when the runs happen on a simulated motor in this process, else nullptr.
  virtual const sim::SimulatedMotor* simulated_motor() const = 0;
  /// Why the oracle commutation cannot be evaluated; "" when it can.
  virtual std::string oracle_unavailable_reason() const = 0;
  /// Live only: what was received; the default says "not live".
  virtual LiveSummary live_summary() const { return {}; }
  /// Remarks for the report (e.g. a run repeated after missing states).
  virtual std::vector<std::string> notes() const { return {}; }
  /// A second runner of the same kind whose runs may go on beside this one's,
  /// on another thread (the evaluations of the laws side by side), started
  /// as this one was; nullptr when there is none (the default: live, there is
  /// one daemon).
  virtual std::unique_ptr<ExperimentRunner> side_runner() const { return nullptr; }
  /// Another runner on the same configuration whose simulated motor keeps
  /// only the error sources `kept`, its dynamics as this one's (the error
  /// budget's runs, docs/commissioning.md "The error budget"); nullptr
  /// without a simulator in this process (the default: live).
  virtual std::unique_ptr<ExperimentRunner> runner_with_sources(sim::ErrorSources /*kept*/) const { return nullptr; }
};

}  // namespace clm::commission
