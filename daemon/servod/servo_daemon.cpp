// ServoDaemon: construction, the routing of a command to what answers it
// (the command table's check first; then the file loader, the move offers,
// the parameter store or the cycle's queue) and the replies, and the
// commands the loop executes between cycles. Files are in
// servo_daemon_files.cpp, the loop in servo_daemon_loop.cpp; moves are
// decided and offered in move_offers.cpp, the run-time parameters kept in
// parameter_store.cpp.
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
  parameters_ = std::make_unique<ParameterStore>(
      config_.servo, config_.loop.rate_hz, config_.plant,
      RuntimeValues{config_.servo.tuning(), config_.control_mass_kg, config_.control_bandwidth_hz});

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
  const auto status = cycle_->start_with(config_.commutation.mode);
  if (status != servo::CommandResult::kAccepted) {
    throw std::runtime_error(config_.origin + ": commutation.mode: " + servo::describe(status));
  }
  commands_ = std::make_unique<telemetry::SpscQueue<servo::Command>>(64);
  replies_ = std::make_unique<telemetry::SpscQueue<RtReply>>(64);
  moves_ = std::make_unique<MoveOffers>(cycle_->mailbox(), *commands_);
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
  if (!commands_->try_push(command)) return reply_to(command, servo::CommandResult::kRejectedQueueFull);
  if (command.kind == servo::CommandKind::kLoadFeedforward) {
    // The cycle takes it without condition: the run-time values follow now.
    parameters_->set_feedforward(command.feedforward);
  }
  return reply_to(command, servo::CommandResult::kQueued);
}

CommandReply ServoDaemon::post_move(const servo::Command& command, const servo::ProgramSteps& program) {
  const servo::AxisSnapshot axis =
      moves_->snapshot(state_seen_.load(std::memory_order_acquire), parameters_->change_pending());
  MoveOffers::Outcome outcome = moves_->post(command, parameters_->planning_settings(), axis, program);
  return reply_to(command, outcome.result, std::move(outcome.detail));
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
    const servo::ServoState state = state_seen_.load(std::memory_order_acquire);
    const bool at_rest = cycle_->mailbox().at_rest();
    if (const Result legal = servo::check_legal(command.kind, state, at_rest); legal != Result::kAccepted) {
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
      case Kind::kSetParameter: {
        // At rest only: the command table (check_legal, above).
        const auto queue_tuning = [&](const servo::Tuning& tuning) {
          command.tuning = tuning;
          return queue(command).result;
        };
        ParameterStore::Answer answer =
            parameters_->set(command.parameter.view(), command.value, command.sequence, command.client, queue_tuning);
        return reply(answer.result, std::move(answer.text));
      }
      case Kind::kMoveTo:
      case Kind::kJog: return post_move(command);
      case Kind::kGetParameter: {
        ParameterStore::Answer answer = parameters_->get(command.parameter.view());
        return reply(answer.result, std::move(answer.text));
      }
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
    // The status names the feedforward file only while its parameters are in use.
    if (parameters_->settle(answered.sequence, answered.client, answered.result)) {
      set_loaded_file(LoadedFileSlot::kFeedforward, "", "");
    }
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
  moves_->collect_garbage();
  std::erase_if(laws_, [&](const std::unique_ptr<OwnedLaw>& law) {
    return !cycle_->mailbox().law(law->mode).in_use(law->law.get());
  });
}

void ServoDaemon::mirror_state() noexcept { state_seen_.store(cycle_->status().state, std::memory_order_release); }

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

void ServoDaemon::obey_safety_requests() noexcept {
  // The tickets before the flags: every ticket read here had its flag set
  // before, so this cycle obeys it (or an earlier one did).
  const std::uint64_t requested = safety_requested_.load(std::memory_order_acquire);
  const std::uint8_t flags = safety_requests_.exchange(0, std::memory_order_acq_rel);
  // Weakest first: a disable latched with a stop leaves the axis disabled.
  for (const auto kind : {servo::CommandKind::kStop, servo::CommandKind::kQuickStop}) {
    if ((flags & safety_bit(kind)) != 0) cycle_->execute({.kind = kind});
  }
  if ((flags & kOwnerGoneBit) != 0) cycle_->owner_gone();
  if ((flags & safety_bit(servo::CommandKind::kDisable)) != 0) cycle_->execute({.kind = servo::CommandKind::kDisable});
  if (flags != 0) mirror_state();
  safety_obeyed_.store(requested, std::memory_order_release);
}

void ServoDaemon::drain_commands() noexcept {
  using Kind = servo::CommandKind;
  obey_safety_requests();
  servo::Command command;
  while (commands_->try_pop(command)) {
    const bool was_pending = cycle_->status().mode_change_pending;
    if (servo::is_move(command.kind)) {
      // Answered once the cycle has taken its program or dropped it.
      awaiting_offer_ = {command.sequence, command.client, servo::CommandResult::kQueued, command.offer};
      answer_offer();
      continue;
    }
    const servo::CommandResult status = cycle_->execute(command);
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
  if (awaiting_offer_.offer == 0 || cycle_->mailbox().offers_decided() < awaiting_offer_.offer) return;
  replies_->try_push({awaiting_offer_.sequence, awaiting_offer_.client, cycle_->status().last_offer_result});
  awaiting_offer_ = {};
}

}  // namespace clm::servod
