#pragma once
// Experiments on the servo daemon (virtual clock): the Algorithm 1/2 data
// runs and the evaluation runs of the commissioning, recorded cycle by cycle.
// No file I/O except the optional LCM log: callers write what they need.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "commutation/commutator.hpp"
#include "daemon/servod/axis_wiring.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "tools/commission/runner.hpp"

namespace clm::commission {

/// The cycles of a program run as recorded: the daemon's record of each
/// (t_s there is the daemon's time; program_time_s the time into the
/// program), and beside it the simulator's truth where there is one.
struct Recording {
  std::string name;
  std::vector<servo::CycleRecord> samples;
  /// y_true_m[k]: the simulated motor's true position at samples[k] [m];
  /// empty without a simulator in this process (live runs).
  std::vector<double> y_true_m;
  /// true_wrench[k]: the electromagnetic wrench samples[k]'s setpoints made
  /// over the period they were in effect (sim::TruthState::step_wrench of
  /// the step after the cycle), without the direction-dependent force and
  /// the sensor's bias and noise, i.e. what the commutation acts on
  /// [N, N, N·m]; empty without a simulator in this process.
  std::vector<Wrench> true_wrench;
  /// static_wrench[k]: what the law in service makes of samples[k]'s F* on
  /// the static truth at the true position y_true_m[k], through an ideal
  /// drive (sim::SimulatedMotor::ideal_drive_wrench): the law's own error,
  /// without the drive's dynamics, the encoder and the timing of the cycle;
  /// NaN where no law was in service (an experiment). Empty without a
  /// simulator in this process [N, N, N·m].
  std::vector<Wrench> static_wrench;
  std::int64_t damping_cycles = 0;
  std::int64_t force_limited_cycles = 0;
};

/// Observer that appends every enabled cycle of a running program, with the
/// true position of `truth` (the simulated motor the daemon drives; nullptr
/// without one), which must outlive the recorder.
class Recorder final : public servod::CycleObserver {
 public:
  explicit Recorder(const sim::SimulatedMotor* truth) : truth_(truth) {}
  void on_cycle(const servo::ServoCycle& cycle, const servod::LoopTiming& timing) noexcept override;
  void start(const std::string& name);
  /// The recording, ended: without its last cycle if the period after it
  /// never ran (its force unknown), so that every vector has one entry per sample.
  Recording finish();
  /// Also hands every recorded cycle to `observer` (e.g. a telemetry bridge
  /// writing an LCM log), or to nobody with nullptr.
  void forward_to(servod::CycleObserver* observer) noexcept { forward_ = observer; }

 private:
  /// Recording::static_wrench of one cycle.
  Wrench static_wrench(const servo::ServoCycle& cycle, const servo::CycleRecord& record, double position_m) noexcept;
  const sim::SimulatedMotor* truth_;
  CommutationOutput law_output_;  ///< static_wrench's scratch
  servod::CycleObserver* forward_ = nullptr;
  Recording recording_;
  bool active_ = false;
  bool awaiting_force_ = false;  ///< the last recorded cycle's true_wrench comes with the next cycle
};

/// Throws std::runtime_error with the daemon's reply text when a command is refused.
void execute(servod::ServoDaemon& daemon, const servo::Command& command);

/// Enables the axis; one at its encoder's power-up offset is homed first
/// (HOME enables, finds the commutation and the reference, docs/servod.md
/// "Homing"), within its search's distance over its velocity plus 30 s of
/// the daemon's time. Throws std::runtime_error on a refusal, a fault or no
/// reference within that time.
void enable_homed(servod::ServoDaemon& daemon);

/// Runs `program` from the program's start (an approach move first, not
/// recorded) and returns the recording of the program proper; `motor` is the
/// simulated motor the daemon drives, for Recording::y_true_m and the
/// disturbance's restart (nullptr: none).
/// With `log` set, the cycles of the program are also written there (one
/// CLM_SERVO_STATE per cycle, status and events) as an LCM log.
Recording run_program(servod::ServoDaemon& daemon, sim::SimulatedMotor* motor, const servod::ProgramFile& program,
                      const std::string& name, servod::CycleObserver* log, Disturbance disturbance);
/// The same on a daemon with its wiring (its simulated motor, if any).
Recording run_program(servod::WiredAxis& axis, const servod::ProgramFile& program, const std::string& name,
                      servod::CycleObserver* log = nullptr, Disturbance disturbance = Disturbance::kRunsOn);

/// The commissioning's runs on a daemon core in this process (the
/// configuration's bus, normally the embedded simulated motor) on the virtual
/// clock: every cycle is recorded, nothing can be dropped. Logs are written
/// with a TelemetryBridge into an LcmLogWriter.
class InProcessRunner final : public ExperimentRunner {
 public:
  /// `config` as given, except: virtual clock, no LCM, original commutation, no feedforward.
  explicit InProcessRunner(const servod::ServodConfig& config);
  /// The same on a wiring the caller built for `config`
  /// (servod::wire_simulated_axis: a motor of other parameters).
  InProcessRunner(const servod::ServodConfig& config, servod::AxisWiring wiring);
  ~InProcessRunner() override;

  void enable() override;
  void set_experiment(int coil_set, double delta_rad) override;
  void set_payload(double payload_kg) override;
  void set_commutation(servo::CommutationMode mode) override;
  void load_calibration(const std::string& path) override;
  void load_model(servo::CommutationMode mode, const std::string& path) override;
  void load_feedforward(const control::FeedforwardParameters& parameters, const std::string& path) override;
  void open_log(const std::string& path) override;
  void close_log() override;
  Recording run_program(const servod::ProgramFile& program, const std::string& program_path,
                        const std::string& name, Disturbance disturbance) override;
  const sim::SimulatedMotor* simulated_motor() const override;
  std::string oracle_unavailable_reason() const override;
  /// Another daemon core on the same configuration, built as this one was;
  /// nullptr when this one runs on a wiring the caller built.
  std::unique_ptr<ExperimentRunner> side_runner() const override;
  std::unique_ptr<ExperimentRunner> runner_with_sources(sim::ErrorSources kept) const override;

 private:
  struct RunLog;
  servod::ServodConfig given_;       ///< the configuration as given
  bool wiring_from_config_ = false;  ///< the wiring is the configuration's (not one the caller built)
  std::unique_ptr<servod::WiredAxis> axis_;
  servod::ServoDaemon* daemon_;  ///< axis_->daemon
  std::unique_ptr<RunLog> log_;
};

}  // namespace clm::commission
