#include "tools/commission/runs.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "daemon/servod/telemetry_bridge.hpp"
#include "daemon/telemetry/telemetry.hpp"
#include "drivers/sim/motor.hpp"

namespace clm::commission {

void Recorder::start(const std::string& name) {
  recording_ = Recording{name, {}, 0, 0};
  recording_.samples.reserve(40000);
  active_ = true;
}

void Recorder::on_cycle(const servo::ServoCycle& cycle, const servod::LoopTiming& timing) noexcept {
  const auto& record = cycle.record();
  if (!active_ || !record.program_running || record.state != servo::ServoState::kEnabled) return;
  Sample s;
  s.t_s = record.program_time_s;
  s.r_m = record.reference.position_m;
  s.r_dot_m_per_s = record.reference.velocity_m_per_s;
  s.r_ddot_m_per_s2 = record.reference.acceleration_m_per_s2;
  s.y_m = record.position_m;
  s.y_true_m = truth_ != nullptr ? truth_->truth().position_m : std::numeric_limits<double>::quiet_NaN();
  s.F_star_N = record.force_demand_N;
  s.u_ff_N = record.feedforward_N;
  s.desired = record.desired_wrench;
  s.measured = record.measured_wrench;
  s.coil_set = record.experiment_coil_set;
  s.delta_rad = record.experiment_delta_rad;
  s.setpoints = record.setpoints;
  s.current_square_sum_A2 = record.current_square_sum_A2;
  if (record.damping_engaged) ++recording_.damping_cycles;
  if (record.force_limited) ++recording_.force_limited_cycles;
  recording_.samples.push_back(s);  // offline tool: the vector was reserved
  if (forward_ != nullptr) forward_->on_cycle(cycle, timing);
}

void execute(servod::ServoDaemon& daemon, servod::DaemonCommand command) {
  const auto reply = daemon.submit(command);
  if (!reply.accepted) throw std::runtime_error("daemon refused a command: " + reply.text);
  daemon.run_cycles(1);
  for (const auto& r : daemon.take_replies()) {
    if (!r.accepted) throw std::runtime_error("daemon refused a command: " + r.text);
  }
}

Recording run_program(servod::ServoDaemon& daemon, const sim::SimulatedMotor* truth, const servod::ProgramFile& program,
                      const std::string& name, servod::CycleObserver* log) {
  using Kind = servod::DaemonCommand::Kind;
  // Approach: move to the start and settle.
  servod::DaemonCommand approach;
  approach.kind = Kind::kMoveTo;
  approach.target_m = program.start_m;
  approach.limits = program.steps.front().limits;
  execute(daemon, approach);
  daemon.run_until_idle(1'000'000);
  daemon.run_cycles(200);

  Recorder recorder(truth);
  recorder.forward_to(log);
  daemon.set_observer(&recorder);
  recorder.start(name);
  servod::DaemonCommand run;
  run.kind = Kind::kRunProgram;
  run.program = program;
  try {
    execute(daemon, run);
    daemon.run_until_idle(10'000'000);
  } catch (...) {
    daemon.set_observer(nullptr);
    throw;
  }
  daemon.set_observer(nullptr);
  if (daemon.cycle().state() != servo::ServoState::kEnabled) {
    throw std::runtime_error("run '" + name + "' ended in fault: " + servo::describe(daemon.cycle().fault()));
  }
  return std::move(recorder.recording());
}

Recording run_program(servod::WiredAxis& axis, const servod::ProgramFile& program, const std::string& name,
                      servod::CycleObserver* log) {
  return run_program(axis.daemon, axis.simulated_motor(), program, name, log);
}

// ---- InProcessRunner -----------------------------------------------------------

struct InProcessRunner::RunLog {
  telemetry::LcmLogWriter writer;
  servod::TelemetryBridge bridge;
  RunLog(const std::string& path, const servod::ServoDaemon& daemon) : writer(path), bridge(writer, daemon, 1) {}
};

namespace {

servod::ServodConfig offline(servod::ServodConfig config) {
  config.loop.clock = servod::ClockMode::kVirtual;
  config.telemetry.enabled = false;
  config.commutation.mode = servo::CommutationMode::kOriginal;
  config.servo.feedforward = {};
  return config;
}

servod::DaemonCommand make(servod::DaemonCommand::Kind kind) {
  servod::DaemonCommand command;
  command.kind = kind;
  return command;
}

}  // namespace

InProcessRunner::InProcessRunner(const servod::ServodConfig& config)
    : axis_(std::make_unique<servod::WiredAxis>(offline(config))), daemon_(&axis_->daemon) {
  daemon_->run_cycles(20);
}

InProcessRunner::~InProcessRunner() = default;

void InProcessRunner::enable() { execute(*daemon_, make(servod::DaemonCommand::Kind::kEnable)); }

void InProcessRunner::set_experiment(int coil_set, double delta_rad) {
  auto command = make(servod::DaemonCommand::Kind::kSetExperiment);
  command.coil_set = coil_set;
  command.delta_rad = delta_rad;
  execute(*daemon_, command);
}

void InProcessRunner::set_commutation(servo::CommutationMode mode) {
  auto command = make(servod::DaemonCommand::Kind::kSetCommutation);
  command.mode = mode;
  execute(*daemon_, command);
  daemon_->run_cycles(5);
}

void InProcessRunner::load_calibration(const std::string& path) {
  auto command = make(servod::DaemonCommand::Kind::kLoadCalibration);
  command.path = path;
  execute(*daemon_, command);
}

void InProcessRunner::load_model(servo::CommutationMode mode, const std::string& path) {
  auto command = make(servod::DaemonCommand::Kind::kLoadModel);
  command.mode = mode;
  command.path = path;
  execute(*daemon_, command);
}

void InProcessRunner::load_feedforward(const control::FeedforwardParameters& parameters, const std::string&) {
  auto command = make(servod::DaemonCommand::Kind::kSetFeedforward);
  command.feedforward = parameters;
  execute(*daemon_, command);
}

void InProcessRunner::open_log(const std::string& path) { log_ = std::make_unique<RunLog>(path, *daemon_); }

void InProcessRunner::close_log() {
  if (log_) log_->writer.close();
  log_.reset();
}

Recording InProcessRunner::run_program(const servod::ProgramFile& program, const std::string&, const std::string& name) {
  return commission::run_program(*axis_, program, name, log_ ? &log_->bridge : nullptr);
}

const sim::SimulatedMotor* InProcessRunner::simulated_motor() const { return axis_->wiring.motor.get(); }

std::string InProcessRunner::oracle_unavailable_reason() const {
  return axis_->wiring.oracle != nullptr ? "" : "no simulator";
}

}  // namespace clm::commission
