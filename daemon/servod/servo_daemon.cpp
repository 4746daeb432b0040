// ServoDaemon: construction, the command path (submit, the cycle's queue and
// its replies, moves and jogs planned and checked), and the commands the loop
// executes between cycles. Files are in servo_daemon_files.cpp, the run-time
// parameters in servo_daemon_parameters.cpp, the loop in servo_daemon_loop.cpp.
#include "daemon/servod/servo_daemon.hpp"

#include <filesystem>
#include <string>
#include <stdexcept>

#include "config/regular_file.hpp"
#include "config/sha256.hpp"
#include "daemon/servod/command_check.hpp"
#include "daemon/servod/servo_daemon_parts.hpp"

namespace clm::servod {

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
  if (status != servo::CommandResult::kAccepted) {
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

std::string CommandReply::text() const {
  std::string words = detail.empty() ? std::string(servo::describe(result)) : detail;
  return accepted() ? words : "rejected: " + words;
}

CommandReply ServoDaemon::queue(const servo::Command& command) {
  if (!commands_->try_push(command)) return reply_to(command, servo::CommandResult::kRejectedQueueFull);
  if (command.kind == servo::CommandKind::kLoadFeedforward) {
    // The cycle takes it without condition: the run-time values follow now.
    std::lock_guard lock(runtime_mutex_);
    runtime_.tuning.feedforward = command.feedforward;
  }
  return reply_to(command, servo::CommandResult::kQueued);
}

servo::AxisSnapshot ServoDaemon::snapshot() const {
  servo::AxisSnapshot axis;
  axis.state = state_seen_.load(std::memory_order_acquire);
  axis.at_rest = cycle_->idle() && !cycle_->program_handover().pending();
  axis.restricted = cycle_->restricted();
  axis.hold_position_m = cycle_->hold_position_m();
  axis.parameter_change_pending = parameter_change_pending();
  axis.jog_running = cycle_->jogging() || cycle_->jog_pending();
  axis.jog_velocity_m_per_s = jog_velocity_m_per_s_;
  axis.jog_limits = jog_limits_;
  return axis;
}

CommandReply ServoDaemon::post_move(const servo::Command& command, const servo::ProgramSteps& program) {
  using Result = servo::CommandResult;
  const auto reply = [&](Result result, std::string detail = "") { return reply_to(command, result, std::move(detail)); };
  servo::MoveDecision decision = servo::decide_move(planning_settings(), snapshot(), command, program);
  if (decision.result == Result::kJogging) {
    // A repeat of the running jog: a renewal that comes after the cycle began
    // its stop is refused, so the answer never says jogging of a jog that stops.
    return reply(cycle_->jog_pending() || cycle_->renew_jog() ? Result::kJogging : Result::kRejectedJogStopping);
  }
  if (!decision.program) return reply(decision.result, std::move(decision.detail));
  auto move = std::make_unique<control::MoveProgram>(std::move(*decision.program));
  // The command goes to the cycle's queue before its program is offered, so
  // the loop knows whom to answer when the cycle takes the offer or drops it
  // (answer_offer). No offer is pending (decide_move saw the axis at rest), so
  // this one is the cycle's next.
  servo::Command posted = command;
  posted.offer = cycle_->offers_decided() + 1;
  if (!commands_->try_push(posted)) return reply(Result::kRejectedQueueFull);
  const bool jog = command.kind == servo::CommandKind::kJog;
  if (!(jog ? cycle_->post_jog(move.get()) : cycle_->program_handover().post(move.get()))) {
    throw std::logic_error("a program was offered while another was pending");
  }
  programs_.push_back(std::move(move));
  if (jog) {
    jog_velocity_m_per_s_ = command.jog_velocity_m_per_s;
    jog_limits_ = command.limits;
  }
  return reply(Result::kQueued);
}

CommandReply ServoDaemon::submit_program(const ProgramFile& program, std::int64_t sequence) {
  collect_garbage();
  servo::Command command;
  command.kind = servo::CommandKind::kRunProgram;
  command.sequence = sequence;
  CommandReply reply;
  try {
    reply = post_move(command, {program.start_m, program.steps});
  } catch (const std::exception& e) {
    reply = {sequence, 0, servo::CommandResult::kRejectedInvalid, e.what()};
  }
  if (!reply.accepted()) refused_.fetch_add(1, std::memory_order_relaxed);
  return reply;
}

CommandReply ServoDaemon::submit(const servo::Command& received) {
  CommandReply reply = answer(received);
  reply.client = received.client;
  if (!reply.accepted()) refused_.fetch_add(1, std::memory_order_relaxed);
  return reply;
}

CommandReply ServoDaemon::answer(const servo::Command& received) {
  using Kind = servo::CommandKind;
  using Result = servo::CommandResult;
  collect_garbage();
  servo::Command command = received;
  const auto reply = [&](Result result, std::string detail = "") { return reply_to(command, result, std::move(detail)); };
  try {
    // The table first: a command the present state does not allow is refused
    // before anything else, a file before it is read.
    const servo::AxisSnapshot axis = snapshot();
    if (const Result legal = servo::check_legal(command.kind, axis.state, axis.at_rest); legal != Result::kAccepted) {
      return reply(legal);
    }
    if (servo::reads_file(command)) {
      if (loader_ == nullptr) {
        auto loaded = load(command);
        return finish_load(*loaded);
      }
      const std::string busy = loader_->start(std::string(servo::file_named(command)), [this, command] {
        auto loaded = load(command);
        std::lock_guard lock(loaded_mutex_);
        loaded_ = std::move(loaded);
      });
      if (!busy.empty()) return reply(Result::kRejectedLoaderBusy, busy);
      return reply(Result::kLoading);
    }
    const std::string reason = check_command(command);
    if (!reason.empty()) return reply(Result::kRejectedInvalid, reason);
    switch (command.kind) {
      case Kind::kSetParameter: return set_parameter(command);
      case Kind::kMoveTo:
      case Kind::kJog: return post_move(command);
      case Kind::kGetParameter: return get_parameter(command);
      default:
        if (servo::answered_by_cycle(command.kind)) return queue(command);
        break;
    }
  } catch (const std::exception& e) {
    return reply(Result::kRejectedInvalid, e.what());
  }
  return reply(Result::kRejectedInvalid, "unknown command " + std::to_string(static_cast<int>(command.kind)));
}

std::vector<CommandReply> ServoDaemon::take_replies() {
  std::vector<CommandReply> out;
  RtReply answered;
  while (replies_->try_pop(answered)) {
    const CommandReply reply{answered.sequence, answered.client, answered.result, ""};
    if (!reply.accepted()) refused_.fetch_add(1, std::memory_order_relaxed);
    settle_parameter_change(answered);
    out.push_back(reply);
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
      answer = reply_to(loaded->command, servo::CommandResult::kRejectedInvalid, e.what());
    }
    if (!answer.accepted()) refused_.fetch_add(1, std::memory_order_relaxed);
    // A program or feedforward went to the cycle: its reply answers it.
    if (!answer.answered_later()) out.push_back(answer);
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

/// request_owner_gone's bit, beside the safety kinds'.
constexpr std::uint8_t kOwnerGoneBit = 8;

}  // namespace

std::uint64_t ServoDaemon::request_safety(servo::CommandKind kind) noexcept {
  return latch_request(safety_bit(kind));
}

std::uint64_t ServoDaemon::request_owner_gone() noexcept { return latch_request(kOwnerGoneBit); }

std::uint64_t ServoDaemon::latch_request(std::uint8_t bit) noexcept {
  // The flag before the ticket: a cycle that has seen the ticket sees the flag.
  safety_requests_.fetch_or(bit, std::memory_order_acq_rel);
  return safety_requested_.fetch_add(1, std::memory_order_acq_rel) + 1;
}

servo::CommandResult ServoDaemon::obey_safety(servo::CommandKind kind) noexcept {
  switch (kind) {
    case servo::CommandKind::kStop: return cycle_->stop();
    case servo::CommandKind::kQuickStop: return cycle_->quick_stop();
    case servo::CommandKind::kDisable: return cycle_->disable();
    default: return servo::CommandResult::kRejectedInvalid;
  }
}

void ServoDaemon::obey_safety_requests() noexcept {
  // The tickets before the flags: every ticket read here had its flag set
  // before, so this cycle obeys it (or an earlier one did).
  const std::uint64_t requested = safety_requested_.load(std::memory_order_acquire);
  const std::uint8_t flags = safety_requests_.exchange(0, std::memory_order_acq_rel);
  // Weakest first: a disable latched with a stop leaves the axis disabled.
  for (const auto kind : {servo::CommandKind::kStop, servo::CommandKind::kQuickStop}) {
    if ((flags & safety_bit(kind)) != 0) obey_safety(kind);
  }
  if ((flags & kOwnerGoneBit) != 0) {
    cycle_->quick_stop();
    cycle_->end_experiment();
  }
  if ((flags & safety_bit(servo::CommandKind::kDisable)) != 0) obey_safety(servo::CommandKind::kDisable);
  if (flags != 0) mirror_state();
  safety_obeyed_.store(requested, std::memory_order_release);
}

void ServoDaemon::drain_commands() noexcept {
  using Kind = servo::CommandKind;
  obey_safety_requests();
  servo::Command command;
  while (commands_->try_pop(command)) {
    servo::CommandResult status = servo::CommandResult::kAccepted;
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
      case Kind::kMoveTo:
      case Kind::kRunProgram:
      case Kind::kJog:
        // Answered once the cycle has taken its program or dropped it.
        awaiting_offer_ = {command.sequence, command.client, servo::CommandResult::kQueued, command.offer};
        answer_offer();
        continue;
      default: status = servo::CommandResult::kRejectedInvalid; break;  // not a kind the cycle answers
    }
    if (command.kind == Kind::kSetCommutation || command.kind == Kind::kSetExperiment) {
      const bool replaced = status == servo::CommandResult::kAccepted || status == servo::CommandResult::kDeferred;
      if (was_pending && replaced) {
        superseded_.superseded = deferred_sequence_;
        superseded_.by = command.sequence;
        ++superseded_.count;
      }
      if (status == servo::CommandResult::kDeferred) deferred_sequence_ = command.sequence;
    }
    honour_disable_request();
    mirror_state();
    replies_->try_push({command.sequence, command.client, status});
  }
  honour_disable_request();
}

void ServoDaemon::answer_offer() noexcept {
  if (awaiting_offer_.offer == 0 || cycle_->offers_decided() < awaiting_offer_.offer) return;
  replies_->try_push({awaiting_offer_.sequence, awaiting_offer_.client, cycle_->last_offer_result()});
  awaiting_offer_ = {};
}

}  // namespace clm::servod
