// ServoDaemon: construction, the command path (submit, the cycle's queue and
// its replies, moves and jogs planned and checked), and the commands the loop
// executes between cycles. Files are in servo_daemon_files.cpp, the run-time
// parameters in servo_daemon_parameters.cpp, the loop in servo_daemon_loop.cpp.
#include "daemon/servod/servo_daemon.hpp"

#include <filesystem>
#include <stdexcept>

#include "config/regular_file.hpp"
#include "config/sha256.hpp"
#include "daemon/servod/command_check.hpp"
#include "daemon/servod/servo_daemon_parts.hpp"

namespace clm::servod {
namespace {

bool reads_file(const servo::Command& command) noexcept {
  using Kind = servo::CommandKind;
  switch (command.kind) {
    case Kind::kRunProgram:
    case Kind::kLoadCalibration:
    case Kind::kLoadModel: return true;
    case Kind::kLoadFeedforward: return !command.path.empty();
    default: return false;
  }
}

}  // namespace

ServoDaemon::ServoDaemon(const ServodConfig& config, drivers::CanBus& bus, drivers::BusClock& clock,
                         std::vector<ExtraLaw> extra_laws)
    : config_(config), bus_(&bus), clock_(&clock), extra_laws_(std::move(extra_laws)) {
  cycle_ = std::make_unique<servo::ServoCycle>(config_.servo);
  runtime_ = {config_.servo.tuning(), config_.control_mass_kg, config_.control_bandwidth_hz};

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
  file_policy_.directories = config_.commands.file_directories;
  file_policy_.max_file_bytes = config_.commands.max_file_bytes;
  for (const auto& [mode, path] : files) {
    if (path.empty()) continue;
    const std::string text = read_regular_file(path, yaml::Node::kMaxFileBytes);
    auto law = build_law(mode, path, text, sha256_hex(text));
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
  update_law_files();
  if (!config_.feedforward_file.empty()) {
    std::error_code error;
    const auto canonical = std::filesystem::canonical(config_.feedforward_file, error);
    set_loaded_file(LoadedFileSlot::kFeedforward, error ? config_.feedforward_file : canonical.string(),
                    sha256_file(config_.feedforward_file));
  }
}

ServoDaemon::~ServoDaemon() = default;

CommandReply ServoDaemon::queue(const servo::Command& command) {
  if (!commands_->try_push(command)) return {command.sequence, false, "command queue full"};
  if (command.kind == servo::CommandKind::kLoadFeedforward) {
    // The cycle takes it without condition: the run-time values follow now.
    std::lock_guard lock(runtime_mutex_);
    runtime_.tuning.feedforward = command.feedforward;
  }
  return {command.sequence, true, "queued"};
}

CommandReply ServoDaemon::post_program(const servo::Command& command, const ProgramFile* program) {
  const servo::ServoState state = state_seen_.load(std::memory_order_acquire);
  if (state == servo::ServoState::kFault) return {command.sequence, false, "rejected: a fault is latched, clear it first"};
  if (state != servo::ServoState::kEnabled) return {command.sequence, false, "rejected: the axis is disabled, enable first"};
  if (!cycle_->idle()) return {command.sequence, false, "rejected: a program is running"};
  if (cycle_->program_handover().pending()) return {command.sequence, false, "rejected: a program is waiting to start"};
  const double hold = cycle_->hold_position_m();
  const auto refuse = [&](const std::string& reason) { return CommandReply{command.sequence, false, "rejected: " + reason}; };
  if (parameter_change_pending()) return refuse("a parameter change is being applied; send the move again");
  const servo::ServoSettings settings = planning_settings();
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
    if (program == nullptr) return refuse("no program");
    const ProgramFile& file = *program;
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

CommandReply ServoDaemon::jog(const servo::Command& command) {
  const auto refuse = [&](const std::string& reason) { return CommandReply{command.sequence, false, "rejected: " + reason}; };
  const servo::ServoState state = state_seen_.load(std::memory_order_acquire);
  if (state == servo::ServoState::kFault) return refuse("a fault is latched, clear it first");
  if (state != servo::ServoState::kEnabled) return refuse("the axis is disabled, enable first");
  if (cycle_->restricted()) return refuse("restricted mode: only a move_to back inside the soft limits is accepted");
  if (parameter_change_pending()) return refuse("a parameter change is being applied; send the jog again");
  const servo::ServoSettings settings = planning_settings();
  if (auto reason = check_motion_limits("jog", command.limits, settings.motion_limits); !reason.empty()) return refuse(reason);
  const auto& l = command.limits;
  const bool same = command.jog_velocity_m_per_s == jog_velocity_m_per_s_ &&
                    l.acceleration_m_per_s2 == jog_limits_.acceleration_m_per_s2 && l.jerk_m_per_s3 == jog_limits_.jerk_m_per_s3;
  if (cycle_->jogging() || cycle_->jog_pending()) {
    // A repeat keeps the jog going (one not yet started starts with a fresh
    // timeout: nothing to renew); anything else waits for it to end.
    if (!same) return refuse("another jog runs: repeat it unchanged, or stop it first");
    if (cycle_->jog_pending() || cycle_->renew_jog()) return {command.sequence, true, "jogging"};
    return refuse("the jog has timed out and is stopping; send it again once the axis is at rest");
  }
  if (!cycle_->idle()) return refuse("a program is running");
  if (cycle_->program_handover().pending()) return refuse("a program is waiting to start");
  // Towards the soft limit, a following-error limit short of it so that the
  // axis, within that of its reference, stays inside.
  const double hold = cycle_->hold_position_m();
  const bool up = command.jog_velocity_m_per_s > 0.0;
  const double band = settings.following_error_limit_m;
  const double target_m = up ? settings.soft_limit_max_m - band : settings.soft_limit_min_m + band;
  if (up ? target_m <= hold : target_m >= hold) return refuse("jog: at the soft limit in that direction already");
  auto move = std::make_unique<control::MoveProgram>(hold, std::vector<control::ProgramStep>{{target_m, l, 0.0}});
  if (auto reason = check_stopping("jog", *move, settings); !reason.empty()) return refuse(reason);
  if (!cycle_->post_jog(move.get())) return refuse("busy");
  programs_.push_back(std::move(move));
  jog_velocity_m_per_s_ = command.jog_velocity_m_per_s;
  jog_limits_ = l;
  return {command.sequence, true, "jog started"};
}

CommandReply ServoDaemon::submit_program(const ProgramFile& program, std::int64_t sequence) {
  collect_garbage();
  servo::Command command;
  command.kind = servo::CommandKind::kRunProgram;
  command.sequence = sequence;
  CommandReply reply;
  try {
    reply = post_program(command, &program);
  } catch (const std::exception& e) {
    reply = {sequence, false, std::string("rejected: ") + e.what()};
  }
  if (!reply.accepted) refused_.fetch_add(1, std::memory_order_relaxed);
  return reply;
}

CommandReply ServoDaemon::submit(const servo::Command& received) {
  CommandReply reply = answer(received);
  reply.client = received.client;
  if (!reply.accepted) refused_.fetch_add(1, std::memory_order_relaxed);
  return reply;
}

CommandReply ServoDaemon::answer(const servo::Command& received) {
  using Kind = servo::CommandKind;
  collect_garbage();
  servo::Command command = received;
  try {
    if (reads_file(command)) {
      if (command.kind == Kind::kRunProgram) {
        // Refused before the file is read: it could not run anyway.
        const servo::ServoState state = state_seen_.load(std::memory_order_acquire);
        if (state == servo::ServoState::kFault) return {command.sequence, false, "rejected: a fault is latched, clear it first"};
        if (state != servo::ServoState::kEnabled) return {command.sequence, false, "rejected: the axis is disabled, enable first"};
      }
      if (loader_ == nullptr) {
        auto loaded = load(command);
        return finish_load(*loaded);
      }
      const std::string path(command.kind == Kind::kRunProgram ? command.program.view() : command.path.view());
      const std::string busy = loader_->start(path, [this, command] {
        auto loaded = load(command);
        std::lock_guard lock(loaded_mutex_);
        loaded_ = std::move(loaded);
      });
      if (!busy.empty()) return {command.sequence, false, "rejected: " + busy};
      CommandReply later{command.sequence, true, "loading"};
      later.answered_later = true;
      return later;
    }
    const std::string reason = check_command(command);
    if (!reason.empty()) return {command.sequence, false, "rejected: " + reason};
    if (command.kind == Kind::kSetParameter) return set_parameter(command);
    if (servo::answered_by_cycle(command.kind)) return queue(command);
    if (command.kind == Kind::kMoveTo) return post_program(command, nullptr);
    if (command.kind == Kind::kJog) return jog(command);
    if (command.kind == Kind::kGetParameter) return get_parameter(command);
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
    if (!ok) refused_.fetch_add(1, std::memory_order_relaxed);
    settle_parameter_change(reply);
    out.push_back({reply.sequence, ok, servo::describe(reply.status), reply.client});
  }
  std::unique_ptr<Loaded> loaded;
  {
    std::lock_guard lock(loaded_mutex_);
    loaded = std::move(loaded_);
  }
  if (loaded) {
    collect_garbage();
    CommandReply answer;
    try {
      answer = finish_load(*loaded);
    } catch (const std::exception& e) {
      answer = {loaded->command.sequence, false, std::string("rejected: ") + e.what(), loaded->command.client};
    }
    if (!answer.accepted) refused_.fetch_add(1, std::memory_order_relaxed);
    // load_feedforward's parameters were queued: the cycle's reply answers it.
    const bool by_cycle = answer.accepted && servo::answered_by_cycle(loaded->command.kind);
    if (!by_cycle) out.push_back(answer);
  }
  update_law_files();
  return out;
}

void ServoDaemon::collect_garbage() {
  update_law_files();
  std::erase_if(programs_, [&](const std::unique_ptr<control::MoveProgram>& program) {
    return !cycle_->program_handover().in_use(program.get());
  });
  std::erase_if(laws_, [&](const std::unique_ptr<OwnedLaw>& law) {
    return !cycle_->law_handover(law->mode).in_use(law->law.get());
  });
}

void ServoDaemon::mirror_state() noexcept { state_seen_.store(cycle_->state(), std::memory_order_release); }

namespace {

std::uint8_t safety_bit(servo::CommandKind kind) noexcept {
  switch (kind) {
    case servo::CommandKind::kStop: return 1;
    case servo::CommandKind::kQuickStop: return 2;
    case servo::CommandKind::kDisable: return 4;
    default: return 0;
  }
}

}  // namespace

std::uint64_t ServoDaemon::request_safety(servo::CommandKind kind) noexcept {
  // The flag before the ticket: a cycle that has seen the ticket sees the flag.
  safety_requests_.fetch_or(safety_bit(kind), std::memory_order_acq_rel);
  return safety_requested_.fetch_add(1, std::memory_order_acq_rel) + 1;
}

servo::CommandStatus ServoDaemon::obey_safety(servo::CommandKind kind) noexcept {
  switch (kind) {
    case servo::CommandKind::kStop: return cycle_->stop();
    case servo::CommandKind::kQuickStop: return cycle_->quick_stop();
    case servo::CommandKind::kDisable: return cycle_->disable();
    default: return servo::CommandStatus::kRejectedInvalid;
  }
}

void ServoDaemon::obey_safety_requests() noexcept {
  // The tickets before the flags: every ticket read here had its flag set
  // before, so this cycle obeys it (or an earlier one did).
  const std::uint64_t requested = safety_requested_.load(std::memory_order_acquire);
  const std::uint8_t flags = safety_requests_.exchange(0, std::memory_order_acq_rel);
  // Weakest first: a disable latched with a stop leaves the axis disabled.
  for (const auto kind : {servo::CommandKind::kStop, servo::CommandKind::kQuickStop, servo::CommandKind::kDisable}) {
    if ((flags & safety_bit(kind)) != 0) obey_safety(kind);
  }
  if (flags != 0) mirror_state();
  safety_obeyed_.store(requested, std::memory_order_release);
}

void ServoDaemon::drain_commands() noexcept {
  using Kind = servo::CommandKind;
  obey_safety_requests();
  servo::Command command;
  while (commands_->try_pop(command)) {
    servo::CommandStatus status = servo::CommandStatus::kAccepted;
    const bool was_pending = cycle_->mode_change_pending();
    switch (command.kind) {
      case Kind::kEnable: status = cycle_->enable(); break;
      case Kind::kDisable:
      case Kind::kStop:
      case Kind::kQuickStop: status = obey_safety(command.kind); break;
      case Kind::kClearFault: status = cycle_->clear_fault(); break;
      case Kind::kSetCommutation: status = cycle_->request_mode(command.commutation); break;
      case Kind::kSetExperiment:
        status = cycle_->request_mode(servo::CommutationMode::kExperiment, command.coil_set, command.delta_rad);
        break;
      case Kind::kLoadFeedforward: cycle_->set_feedforward(command.feedforward); break;
      case Kind::kSetParameter: status = cycle_->apply_tuning(command.tuning); break;
      default: status = servo::CommandStatus::kRejectedInvalid; break;  // not a kind the cycle answers
    }
    if (command.kind == Kind::kSetCommutation || command.kind == Kind::kSetExperiment) {
      const bool replaced = status == servo::CommandStatus::kAccepted || status == servo::CommandStatus::kDeferred;
      if (was_pending && replaced) {
        superseded_.superseded = deferred_sequence_;
        superseded_.by = command.sequence;
        ++superseded_.count;
      }
      if (status == servo::CommandStatus::kDeferred) deferred_sequence_ = command.sequence;
    }
    honour_disable_request();
    mirror_state();
    replies_->try_push({command.sequence, command.client, status});
  }
  honour_disable_request();
}

}  // namespace clm::servod
