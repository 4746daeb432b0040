#include "daemon/servod/servo_daemon.hpp"

#include <time.h>

#include <stdexcept>

#include "daemon/servod/command_check.hpp"
#include "daemon/servod/wakeup_schedule.hpp"

namespace clm::servod {
namespace {

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleep_until(std::int64_t time_ns) noexcept {
  timespec ts{};
  ts.tv_sec = time_ns / 1'000'000'000;
  ts.tv_nsec = time_ns % 1'000'000'000;
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace

struct ServoDaemon::RtReply {
  std::int64_t sequence = 0;
  std::int64_t client = 0;
  servo::CommandStatus status = servo::CommandStatus::kAccepted;
};

// A law with the files it was built from; the law refers into them.
struct ServoDaemon::OwnedLaw {
  servo::CommutationMode mode = servo::CommutationMode::kOriginal;
  std::string source;
  CalibrationFile calibration;
  std::vector<ClassicalEstimate> estimates;
  ModelFile model;
  std::unique_ptr<CommutationLaw> law;
};

ServoDaemon::ServoDaemon(const ServodConfig& config, drivers::CanBus& bus, drivers::BusClock& clock,
                         std::vector<ExtraLaw> extra_laws)
    : config_(config), bus_(&bus), clock_(&clock), extra_laws_(std::move(extra_laws)) {
  cycle_ = std::make_unique<servo::ServoCycle>(config_.servo);

  // The drive's own law, always available.
  auto original = std::make_unique<OwnedLaw>();
  original->mode = servo::CommutationMode::kOriginal;
  original->source = "drive commutation";
  original->estimates.assign(static_cast<std::size_t>(config_.motor.coil_sets),
                             {config_.motor.drive.motor_constant_N_per_A, config_.motor.drive.phase_offset_rad});
  original->law = std::make_unique<ClassicalCommutator>(original->estimates, config_.motor.pole_pitch_m,
                                                        config_.motor.drive, config_.commutation.options.phase_convention);
  cycle_->install_law(servo::CommutationMode::kOriginal, original->law.get());
  laws_.push_back(std::move(original));
  const std::pair<servo::CommutationMode, std::string> files[] = {
      {servo::CommutationMode::kClassical, config_.commutation.calibration_file},
      {servo::CommutationMode::kPgnn, config_.commutation.pgnn_model_file},
      {servo::CommutationMode::kSpline, config_.commutation.spline_model_file},
  };
  for (const auto& [mode, path] : files) {
    if (path.empty()) continue;
    auto law = build_law(mode, path);
    cycle_->install_law(mode, law->law.get());
    laws_.push_back(std::move(law));
  }
  for (const ExtraLaw& extra : extra_laws_) cycle_->install_law(extra.mode, extra.law);
  const auto status = cycle_->request_mode(config_.commutation.mode);
  if (status != servo::CommandStatus::kAccepted) {
    throw std::runtime_error(config_.origin + ": commutation.mode: " + servo::describe(status));
  }
  commands_ = std::make_unique<telemetry::SpscQueue<servo::Command>>(64);
  replies_ = std::make_unique<telemetry::SpscQueue<RtReply>>(64);
}

ServoDaemon::~ServoDaemon() = default;

std::string ServoDaemon::law_source(servo::CommutationMode mode) const {
  // The law the cycle uses now; one still waiting for standstill is not it.
  for (const auto& law : laws_) {
    if (law->mode == mode && cycle_->law_handover(mode).is_current(law->law.get())) return law->source;
  }
  for (const ExtraLaw& extra : extra_laws_) {
    if (extra.mode == mode && cycle_->law_handover(mode).is_current(extra.law)) return extra.source;
  }
  return "";
}

std::unique_ptr<ServoDaemon::OwnedLaw> ServoDaemon::build_law(servo::CommutationMode mode, const std::string& path) const {
  auto owned = std::make_unique<OwnedLaw>();
  owned->mode = mode;
  owned->source = path;
  if (mode == servo::CommutationMode::kClassical) {
    owned->calibration = load_calibration_file(path);
    check_matches_motor(owned->calibration, config_.motor, path, config_.motor_file);
    owned->estimates = owned->calibration.estimates();
    owned->law = std::make_unique<ClassicalCommutator>(owned->estimates, config_.motor.pole_pitch_m, config_.motor.drive,
                                                       config_.commutation.options.phase_convention);
  } else {
    owned->model = load_model_file(path);
    check_matches_motor(owned->model.model, config_.motor, path, config_.motor_file);
    const ModelKind expected = mode == servo::CommutationMode::kPgnn ? ModelKind::kPgnn : ModelKind::kSpline;
    if (owned->model.model.kind != expected) {
      throw std::runtime_error(path + ": kind: the file holds a " +
                               std::string(owned->model.model.kind == ModelKind::kPgnn ? "pgnn" : "spline") +
                               " model, the " + servo::name(mode) + " commutation needs a " +
                               (expected == ModelKind::kPgnn ? "pgnn" : "spline") + " model");
    }
    owned->law = std::make_unique<ModelCommutator>(owned->model.model, config_.motor.drive, config_.commutation.options);
  }
  return owned;
}

CommandReply ServoDaemon::queue(const servo::Command& command) {
  if (!commands_->try_push(command)) return {command.sequence, false, "command queue full"};
  return {command.sequence, true, "queued"};
}

CommandReply ServoDaemon::post_program(const servo::Command& command, const ProgramFile* program) {
  if (!cycle_->idle()) return {command.sequence, false, "rejected: a program is running"};
  if (cycle_->program_handover().pending()) return {command.sequence, false, "rejected: a program is waiting to start"};
  const double hold = cycle_->hold_position_m();
  const servo::ServoSettings& settings = config_.servo;
  const auto refuse = [&](const std::string& reason) { return CommandReply{command.sequence, false, "rejected: " + reason}; };
  // Restricted mode (after kPositionOutOfRange): only a slow move back inside.
  const bool restricted = cycle_->restricted();
  std::unique_ptr<control::MoveProgram> move;
  if (command.kind == servo::CommandKind::kMoveTo) {
    if (!(command.target_m >= settings.soft_limit_min_m && command.target_m <= settings.soft_limit_max_m)) {
      return refuse(restricted ? "restricted mode: the target must lie inside the soft limits"
                               : "target outside the soft limits");
    }
    control::MotionLimits max = settings.motion_limits;
    if (restricted) max.velocity_m_per_s *= settings.recovery_velocity_fraction;
    if (auto reason = check_motion_limits(restricted ? "move_to (restricted mode)" : "move_to", command.limits, max);
        !reason.empty()) {
      return refuse(reason);
    }
    move = std::make_unique<control::MoveProgram>(
        hold, std::vector<control::ProgramStep>{{command.target_m, command.limits, 0.0}});
    // In restricted mode the move starts outside; it only goes back inside.
    if (!restricted) {
      if (auto reason = check_stopping("move_to", *move, settings); !reason.empty()) return refuse(reason);
    }
  } else {
    if (restricted) return refuse("restricted mode: only a move_to back inside the soft limits is accepted");
    const ProgramFile file = program != nullptr ? *program : load_program_file(std::string(command.program.view()));
    for (std::size_t i = 0; i < file.steps.size(); ++i) {
      const auto& step = file.steps[i];
      if (step.target_m < settings.soft_limit_min_m || step.target_m > settings.soft_limit_max_m) {
        return refuse("a program target lies outside the soft limits");
      }
      if (auto reason = check_motion_limits("run_program: step " + std::to_string(i + 1), step.limits,
                                            settings.motion_limits);
          !reason.empty()) {
        return refuse(reason);
      }
    }
    move = std::make_unique<control::MoveProgram>(program_from(file, hold));
    if (auto reason = check_stopping("run_program", *move, settings); !reason.empty()) return refuse(reason);
  }
  if (!cycle_->program_handover().post(move.get())) return {command.sequence, false, "rejected: busy"};
  programs_.push_back(std::move(move));
  return {command.sequence, true, "program posted"};
}

CommandReply ServoDaemon::submit_program(const ProgramFile& program, std::int64_t sequence) {
  collect_garbage();
  servo::Command command;
  command.kind = servo::CommandKind::kRunProgram;
  command.sequence = sequence;
  try {
    return post_program(command, &program);
  } catch (const std::exception& e) {
    return {sequence, false, std::string("rejected: ") + e.what()};
  }
}

CommandReply ServoDaemon::submit(const servo::Command& received) {
  CommandReply reply = answer(received);
  reply.client = received.client;
  return reply;
}

CommandReply ServoDaemon::answer(const servo::Command& received) {
  using Kind = servo::CommandKind;
  collect_garbage();
  servo::Command command = received;
  try {
    const std::string reason = check_command(command);
    if (!reason.empty()) return {command.sequence, false, "rejected: " + reason};
    if (servo::answered_by_cycle(command.kind)) return queue(command);
    switch (command.kind) {
      case Kind::kMoveTo:
      case Kind::kRunProgram:
        return post_program(command, nullptr);
      case Kind::kLoadCalibration:
      case Kind::kLoadModel: {
        const servo::CommutationMode mode =
            command.kind == Kind::kLoadCalibration ? servo::CommutationMode::kClassical : command.commutation;
        if (mode != servo::CommutationMode::kClassical && mode != servo::CommutationMode::kPgnn &&
            mode != servo::CommutationMode::kSpline) {
          return {command.sequence, false, "rejected: models load into pgnn or spline"};
        }
        auto law = build_law(mode, std::string(command.path.view()));  // throws on any problem: the running law stays
        if (!cycle_->law_handover(mode).post(law->law.get())) {
          return {command.sequence, false, "rejected: an earlier load is still waiting for standstill"};
        }
        laws_.push_back(std::move(law));
        return {command.sequence, true, "loaded; swapped in at the next standstill"};
      }
      default:
        break;
    }
  } catch (const std::exception& e) {
    return {command.sequence, false, std::string("rejected: ") + e.what()};
  }
  return {command.sequence, false, "unknown command"};
}

std::vector<CommandReply> ServoDaemon::take_replies() {
  std::vector<CommandReply> out;
  RtReply reply;
  while (replies_->try_pop(reply)) {
    const bool ok = reply.status == servo::CommandStatus::kAccepted || reply.status == servo::CommandStatus::kDeferred;
    out.push_back({reply.sequence, ok, servo::describe(reply.status), reply.client});
  }
  return out;
}

void ServoDaemon::collect_garbage() {
  std::erase_if(programs_, [&](const std::unique_ptr<control::MoveProgram>& program) {
    return !cycle_->program_handover().in_use(program.get());
  });
  std::erase_if(laws_, [&](const std::unique_ptr<OwnedLaw>& law) {
    return !cycle_->law_handover(law->mode).in_use(law->law.get());
  });
}

void ServoDaemon::drain_commands() noexcept {
  using Kind = servo::CommandKind;
  servo::Command command;
  while (commands_->try_pop(command)) {
    servo::CommandStatus status = servo::CommandStatus::kAccepted;
    switch (command.kind) {
      case Kind::kEnable: status = cycle_->enable(); break;
      case Kind::kDisable: status = cycle_->disable(); break;
      case Kind::kClearFault: status = cycle_->clear_fault(); break;
      case Kind::kStop: status = cycle_->stop(); break;
      case Kind::kQuickStop: status = cycle_->quick_stop(); break;
      case Kind::kSetCommutation: status = cycle_->request_mode(command.commutation); break;
      case Kind::kSetExperiment:
        status = cycle_->request_mode(servo::CommutationMode::kExperiment, command.coil_set, command.delta_rad);
        break;
      case Kind::kLoadFeedforward: cycle_->set_feedforward(command.feedforward); break;
      default: status = servo::CommandStatus::kRejectedInvalid; break;  // not a kind the cycle answers
    }
    replies_->try_push({command.sequence, command.client, status});
  }
}

void ServoDaemon::one_cycle(std::int64_t sync_time_ns, std::int64_t deadline_ns, double time_s,
                            std::int64_t next_sync_ns, bool realtime) noexcept {
  drain_commands();
  clock_->advance_to(sync_time_ns);
  const can::Frame sync = cycle_->begin_cycle(sync_time_ns);
  bool send_failed = !bus_->send(sync);
  drivers::ReceivedFrame received;
  while (!cycle_->feedback_complete() && bus_->receive(received, deadline_ns)) cycle_->on_frame(received);
  // A bus fault known before the setpoints are built already zeroes this
  // cycle's setpoints; a failing setpoint send is reported after them.
  cycle_->report_bus(bus_->state(), send_failed);
  const auto frames = cycle_->end_cycle(time_s);
  // Setpoints never outlive their cycle: past the next SYNC they are dropped.
  if (realtime && monotonic_ns() >= next_sync_ns) {
    ++timing_.late_setpoints;
  } else {
    for (const auto& frame : frames) send_failed = !bus_->send(frame) || send_failed;
  }
  cycle_->report_bus(bus_->state(), send_failed);
  if (observer_ != nullptr) observer_->on_cycle(*cycle_, timing_);
  cycles_done_.fetch_add(1, std::memory_order_release);
}

void ServoDaemon::run_cycles(std::int64_t cycles) {
  const auto period_ns = static_cast<std::int64_t>(config_.servo.period_s * 1e9);
  for (std::int64_t k = 0; k < cycles; ++k) {
    virtual_time_ns_ += period_ns;
    one_cycle(virtual_time_ns_, virtual_time_ns_ + period_ns / 2, static_cast<double>(virtual_time_ns_) * 1e-9,
              virtual_time_ns_ + period_ns, false);
  }
}

std::int64_t ServoDaemon::run_until_idle(std::int64_t max_cycles) {
  std::int64_t done = 0;
  // One cycle first so a freshly posted program is adopted.
  while (done < max_cycles) {
    run_cycles(1);
    ++done;
    if (cycle_->idle() && !cycle_->program_handover().pending()) break;
  }
  return done;
}

void ServoDaemon::run_realtime(const std::atomic<bool>& stop) {
  const auto period_ns = static_cast<std::int64_t>(config_.servo.period_s * 1e9);
  const auto window_ns = static_cast<std::int64_t>(config_.loop.receive_window_fraction * static_cast<double>(period_ns));
  const std::int64_t start_ns = monotonic_ns();
  WakeupSchedule schedule(start_ns + period_ns, period_ns);
  while (!stop.load(std::memory_order_acquire)) {
    const std::int64_t planned = schedule.next_ns();
    sleep_until(planned);
    const std::int64_t wake = monotonic_ns();
    timing_.wakeup_latency.add(static_cast<double>(wake - planned) * 1e-9);
    one_cycle(wake, planned + window_ns, static_cast<double>(planned - start_ns) * 1e-9, planned + period_ns, true);
    const std::int64_t done = monotonic_ns();
    timing_.compute_time.add(static_cast<double>(done - wake) * 1e-9);
    const std::int64_t missed = schedule.advance(done);
    timing_.missed_deadlines += missed;
    cycle_->report_overrun(missed > 0);
  }
}

}  // namespace clm::servod
