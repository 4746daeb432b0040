#include "tools/commission/runs.hpp"

#include <limits>
#include <stdexcept>
#include <utility>

#include "daemon/servod/telemetry_bridge.hpp"
#include "daemon/telemetry/telemetry.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/parameters.hpp"

namespace clm::commission {

void Recorder::start(const std::string& name) {
  recording_ = Recording{};
  recording_.name = name;
  recording_.samples.reserve(40000);
  if (truth_ != nullptr) {
    recording_.y_true_m.reserve(40000);
    recording_.true_wrench.reserve(40000);
    recording_.static_wrench.reserve(40000);
  }
  active_ = true;
}

void Recorder::on_cycle(const servo::ServoCycle& cycle, const servod::LoopTiming& timing) noexcept {
  // The force the last recorded cycle's setpoints made is known once the
  // simulated motor has stepped through the period they were in effect.
  const bool truth_wanted = truth_ != nullptr && (awaiting_force_ || active_);
  const sim::TruthState truth = truth_wanted ? truth_->truth() : sim::TruthState{};
  if (truth_ != nullptr && awaiting_force_) recording_.true_wrench.push_back(truth.step_wrench);
  awaiting_force_ = false;
  const auto& record = cycle.record();
  if (!active_ || !record.program_running || record.state != servo::ServoState::kEnabled) return;
  if (truth_ != nullptr) {
    recording_.y_true_m.push_back(truth.position_m);
    recording_.static_wrench.push_back(static_wrench(cycle, record, truth.position_m));
    awaiting_force_ = true;
  }
  if (record.damping_engaged) ++recording_.damping_cycles;
  if (record.force_limited) ++recording_.force_limited_cycles;
  recording_.samples.push_back(record);  // offline tool: the vectors were reserved
  if (forward_ != nullptr) forward_->on_cycle(cycle, timing);
}

Wrench Recorder::static_wrench(const servo::ServoCycle& cycle, const servo::CycleRecord& record,
                               double position_m) noexcept {
  const CommutationLaw* law =
      record.commutation == servo::CommutationMode::kExperiment ? nullptr : cycle.law(record.commutation);
  if (law == nullptr) return Wrench::Constant(std::numeric_limits<double>::quiet_NaN());
  law->commutate(position_m, Wrench(record.Fy_star_N, record.Fx_star_N, record.Tz_star_Nm), law_output_);
  const auto count = static_cast<std::size_t>(law_output_.coil_sets);
  std::array<PhaseCurrentSetpoint, kMaxCoilSets> currents{};
  for (std::size_t l = 0; l < count; ++l) {
    const auto i = static_cast<Eigen::Index>(2 * l);
    currents[l] = {law_output_.currents_A[i], law_output_.currents_A[i + 1]};
  }
  return truth_->ideal_drive_wrench(position_m, std::span(law_output_.setpoints).first(count),
                                    std::span(currents).first(count));
}

Recording Recorder::finish() {
  active_ = false;
  if (awaiting_force_) {
    // The last cycle's period never ran: its force is unknown, so it is not kept.
    recording_.samples.pop_back();
    recording_.y_true_m.pop_back();
    recording_.static_wrench.pop_back();
    awaiting_force_ = false;
  }
  return std::move(recording_);
}

namespace {

/// A command the in-process daemon refused.
class CommandRefused : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

void check_reply(const servod::CommandReply& reply) {
  if (!reply.accepted()) throw CommandRefused("daemon refused a command: " + reply.text());
}

/// execute(), a refusal thrown as LawRefused.
void load_law_file(servod::ServoDaemon& daemon, const servo::Command& command) {
  try {
    execute(daemon, command);
  } catch (const CommandRefused& refused) {
    throw LawRefused(refused.what());
  }
}

void run_reply_cycle(servod::ServoDaemon& daemon) {
  daemon.run_cycles(1);
  for (const auto& r : daemon.take_replies()) check_reply(r);
}

}  // namespace

void execute(servod::ServoDaemon& daemon, const servo::Command& command) {
  check_reply(daemon.submit(command));
  run_reply_cycle(daemon);
}

Recording run_program(servod::ServoDaemon& daemon, sim::SimulatedMotor* motor, const servod::ProgramFile& program,
                      const std::string& name, servod::CycleObserver* log, Disturbance disturbance) {
  // Approach: move to the start and settle.
  servo::Command approach;
  approach.kind = servo::CommandKind::kMoveTo;
  approach.target_m = program.start_m;
  approach.limits = program.steps.front().limits;
  execute(daemon, approach);
  daemon.run_until_idle(1'000'000);
  daemon.run_cycles(200);

  if (motor != nullptr && disturbance == Disturbance::kRestarts) motor->restart_disturbance();
  Recorder recorder(motor);
  recorder.forward_to(log);
  daemon.set_observer(&recorder);
  recorder.start(name);
  try {
    check_reply(daemon.submit_program(program));
    run_reply_cycle(daemon);
    daemon.run_until_idle(10'000'000);
  } catch (...) {
    daemon.set_observer(nullptr);
    throw;
  }
  daemon.set_observer(nullptr);
  if (daemon.cycle().status().state != servo::ServoState::kEnabled) {
    throw std::runtime_error("run '" + name + "' ended in fault: " + servo::describe(daemon.cycle().status().fault));
  }
  return recorder.finish();
}

Recording run_program(servod::WiredAxis& axis, const servod::ProgramFile& program, const std::string& name,
                      servod::CycleObserver* log, Disturbance disturbance) {
  return run_program(axis.daemon, axis.simulated_motor(), program, name, log, disturbance);
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

servo::Command make(servo::CommandKind kind) {
  servo::Command command;
  command.kind = kind;
  return command;
}

/// `path` as a command's path; throws when it does not fit.
servo::PathText path_text(const std::string& path) {
  servo::PathText text;
  if (!text.assign(path)) {
    throw std::runtime_error(path + ": path longer than " + std::to_string(servo::PathText::kMaxChars) +
                             " characters, the daemon's limit");
  }
  return text;
}

}  // namespace

InProcessRunner::InProcessRunner(const servod::ServodConfig& config) : InProcessRunner(config, servod::wire_axis(config)) {
  wiring_from_config_ = true;
}

InProcessRunner::InProcessRunner(const servod::ServodConfig& config, servod::AxisWiring wiring)
    : given_(config),
      axis_(std::make_unique<servod::WiredAxis>(offline(config), std::move(wiring))),
      daemon_(&axis_->daemon) {
  daemon_->run_cycles(20);
}

InProcessRunner::~InProcessRunner() = default;

void enable_homed(servod::ServoDaemon& daemon) {
  const auto& homing = daemon.config().servo.homing;
  if (homing.incremental() && !daemon.cycle().status().homed) {
    execute(daemon, make(servo::CommandKind::kHome));
    const double search_s = homing.search_distance_m / homing.search_velocity_m_per_s + 30.0;
    const auto most = static_cast<std::int64_t>(search_s / daemon.config().servo.period_s);
    for (std::int64_t k = 0; k < most; ++k) {
      const auto& status = daemon.cycle().status();
      if (status.state == servo::ServoState::kFault) {
        throw std::runtime_error(std::string("homing ended in fault: ") + servo::describe(status.fault));
      }
      if (status.homed && status.homing == servo::HomingPhase::kIdle && !status.enabling) return;
      daemon.run_cycles(1);
    }
    throw std::runtime_error("the axis was not homed within " + std::to_string(search_s) + " s of simulated time");
  }
  execute(daemon, make(servo::CommandKind::kEnable));
}

void InProcessRunner::enable() { enable_homed(*daemon_); }

void InProcessRunner::set_experiment(int coil_set, double delta_rad) {
  auto command = make(servo::CommandKind::kSetExperiment);
  command.coil_set = coil_set;
  command.delta_rad = delta_rad;
  execute(*daemon_, command);
}

void InProcessRunner::set_payload(double payload_kg) {
  if (axis_->wiring.motor == nullptr) throw std::runtime_error("payload: the axis has no simulated motor");
  axis_->wiring.motor->set_payload_kg(payload_kg);
}

void InProcessRunner::set_commutation(servo::CommutationMode mode) {
  auto command = make(servo::CommandKind::kSetCommutation);
  command.commutation = mode;
  execute(*daemon_, command);
  daemon_->run_cycles(5);
}

void InProcessRunner::load_calibration(const std::string& path) {
  auto command = make(servo::CommandKind::kLoadCalibration);
  command.path = path_text(path);
  load_law_file(*daemon_, command);
}

void InProcessRunner::load_model(servo::CommutationMode mode, const std::string& path) {
  auto command = make(servo::CommandKind::kLoadModel);
  command.commutation = mode;
  command.path = path_text(path);
  load_law_file(*daemon_, command);
}

void InProcessRunner::load_feedforward(const control::FeedforwardParameters& parameters, const std::string&) {
  auto command = make(servo::CommandKind::kLoadFeedforward);  // no path: the parameters as given
  command.feedforward = parameters;
  execute(*daemon_, command);
}

void InProcessRunner::open_log(const std::string& path) { log_ = std::make_unique<RunLog>(path, *daemon_); }

void InProcessRunner::close_log() {
  if (log_) log_->writer.close();
  log_.reset();
}

Recording InProcessRunner::run_program(const servod::ProgramFile& program, const std::string&, const std::string& name,
                                       Disturbance disturbance) {
  // The log holds the runs only: the approach and the time between runs are left out on purpose.
  if (log_) {
    const auto& last = daemon_->cycle().record();
    telemetry::mark_recording_resumed(log_->writer, last.cycle, last.utime);
  }
  return commission::run_program(*axis_, program, name, log_ ? &log_->bridge : nullptr, disturbance);
}

const sim::SimulatedMotor* InProcessRunner::simulated_motor() const { return axis_->wiring.motor.get(); }

std::unique_ptr<ExperimentRunner> InProcessRunner::side_runner() const {
  if (!wiring_from_config_) return nullptr;
  return std::make_unique<InProcessRunner>(given_);
}

std::unique_ptr<ExperimentRunner> InProcessRunner::runner_with_sources(sim::ErrorSources kept) const {
  const sim::SimulatedMotor* motor = simulated_motor();
  if (motor == nullptr) return nullptr;
  return std::make_unique<InProcessRunner>(
      given_, servod::wire_simulated_axis(given_, sim::with_error_sources(motor->parameters(), kept)));
}

std::string InProcessRunner::oracle_unavailable_reason() const {
  return axis_->wiring.oracle != nullptr ? "" : "no simulator";
}

}  // namespace clm::commission
