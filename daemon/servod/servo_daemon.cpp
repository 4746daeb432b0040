#include "daemon/servod/servo_daemon.hpp"

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <type_traits>

#include "config/regular_file.hpp"
#include "config/sha256.hpp"
#include "daemon/servod/command_check.hpp"
#include "daemon/servod/feedforward_file.hpp"

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

/// Where in the file a parser message points ("line 3, key kind"), read from
/// its "<file>:<line>: <key>: ..." prefix; "" when it has none. Nothing after
/// the key is kept: that part may quote the file's content.
std::string where_in_file(const std::string& message, const std::string& file) {
  if (message.compare(0, file.size(), file) != 0 || message.size() <= file.size() || message[file.size()] != ':') {
    return "";
  }
  std::size_t at = file.size() + 1;
  std::string line;
  while (at < message.size() && message[at] >= '0' && message[at] <= '9') line += message[at++];
  if (!line.empty() && at < message.size() && message[at] == ':') ++at;
  std::string key;
  if (at < message.size() && message[at] == ' ') {
    const std::size_t end = message.find(": ", at + 1);
    if (end != std::string::npos) key = message.substr(at + 1, end - at - 1);
  }
  if (key.size() > 64 || key.find_first_of("' ") != std::string::npos) key.clear();  // not a key path
  std::string where;
  if (!line.empty()) where = "line " + line;
  if (!key.empty()) where += (where.empty() ? "key " : ", key ") + key;
  return where;
}

const char* file_kind(servo::CommandKind kind) noexcept {
  switch (kind) {
    case servo::CommandKind::kRunProgram: return "program";
    case servo::CommandKind::kLoadCalibration: return "calibration";
    case servo::CommandKind::kLoadModel: return "model";
    case servo::CommandKind::kLoadFeedforward: return "feedforward";
    default: return "input";
  }
}

}  // namespace

// What the loader read from one command's file.
struct ServoDaemon::Loaded {
  servo::Command command;
  std::string refusal;  // "" when loaded
  std::string canonical, sha256;
  std::unique_ptr<OwnedLaw> law;
  ProgramFile program;
};

// A law with the files it was built from; the law refers into them.
struct ServoDaemon::OwnedLaw {
  servo::CommutationMode mode = servo::CommutationMode::kOriginal;
  std::string source;  // canonical path of its file
  std::string sha256;  // of its file
  CalibrationFile calibration;
  std::vector<ClassicalEstimate> estimates;
  ModelFile model;
  std::unique_ptr<CommutationLaw> law;
};

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

std::unique_ptr<ServoDaemon::OwnedLaw> ServoDaemon::build_law(servo::CommutationMode mode, const std::string& path,
                                                             const std::string& text, const std::string& sha256) const {
  auto owned = std::make_unique<OwnedLaw>();
  owned->mode = mode;
  std::error_code error;
  const auto canonical = std::filesystem::canonical(path, error);
  owned->source = error ? path : canonical.string();
  owned->sha256 = sha256;
  if (mode == servo::CommutationMode::kClassical) {
    owned->calibration = parse_calibration_file(yaml::Node::load_string(text, path));
    check_matches_motor(owned->calibration, config_.motor, path, config_.motor_file);
    owned->estimates = owned->calibration.estimates();
    owned->law = std::make_unique<ClassicalCommutator>(owned->estimates, config_.motor.pole_pitch_m, config_.motor.drive,
                                                       config_.commutation.options.phase_convention);
  } else {
    owned->model = parse_model_file(yaml::Node::load_string(text, path));
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
  if (cycle_->jogging()) {
    // A repeat keeps the running jog going; anything else waits for it to end.
    if (!same) return refuse("another jog runs: repeat it unchanged, or stop it first");
    if (cycle_->renew_jog()) return {command.sequence, true, "jogging"};
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

std::unique_ptr<ServoDaemon::Loaded> ServoDaemon::load(const servo::Command& command) const {
  using Kind = servo::CommandKind;
  auto loaded = std::make_unique<Loaded>();
  loaded->command = command;
  const std::string path(command.kind == Kind::kRunProgram ? command.program.view() : command.path.view());
  const std::string rejected = std::string("rejected: ") + servo::route(command.kind).name + ": ";
  const std::string refusal = check_loadable(file_policy_, path, loaded->canonical);
  if (!refusal.empty()) {
    // The rule first, the path last: an ack's text is short, a long path is cut.
    const std::string quoted = "'" + path + "': ";
    loaded->refusal = refusal.compare(0, quoted.size(), quoted) == 0
                          ? rejected + refusal.substr(quoted.size()) + ": '" + path + "'"
                          : rejected + refusal;
    return loaded;
  }
  const std::string& file = loaded->canonical;
  try {
    const std::string text = read_regular_file(file, static_cast<std::uint64_t>(file_policy_.max_file_bytes),
                                               " (commands.max_file_bytes)");
    loaded->sha256 = sha256_hex(text);
    switch (command.kind) {
      case Kind::kRunProgram:
        loaded->program = parse_program_file(yaml::Node::load_string(text, file));
        break;
      case Kind::kLoadFeedforward: {
        loaded->command.feedforward = parse_feedforward_file(yaml::Node::load_string(text, file)).parameters;
        const auto& ff = loaded->command.feedforward;
        for (const auto& [key, value] : {std::pair{"mass_kg", ff.mass_kg}, std::pair{"viscous_N_s_per_m", ff.viscous_N_s_per_m},
                                         std::pair{"coulomb_N", ff.coulomb_N}}) {
          if (!std::isfinite(value)) throw std::runtime_error(file + ": " + key + ": not a finite number");
        }
        break;
      }
      case Kind::kLoadCalibration:
        loaded->law = build_law(servo::CommutationMode::kClassical, file, text, loaded->sha256);
        break;
      case Kind::kLoadModel: {
        servo::CommutationMode mode = command.commutation;
        if (mode != servo::CommutationMode::kPgnn && mode != servo::CommutationMode::kSpline) {
          // servo_command_t names no law: the model file's own `kind:` says which.
          const ModelFile model = parse_model_file(yaml::Node::load_string(text, file));
          mode = model.model.kind == ModelKind::kPgnn ? servo::CommutationMode::kPgnn : servo::CommutationMode::kSpline;
          loaded->command.commutation = mode;
        }
        loaded->law = build_law(mode, file, text, loaded->sha256);
        break;
      }
      default:
        loaded->refusal = rejected + "not a command that loads a file";
        break;
    }
  } catch (const std::exception& e) {
    // The parser's message may quote the file: in full to the log only.
    const std::string message = e.what();
    if (log_) {
      log_("refused " + std::string(file_kind(command.kind)) + " file '" + path + "': " + message);
    } else {
      std::fprintf(stderr, "clm-servod: refused %s file '%s': %s\n", file_kind(command.kind), path.c_str(),
                   message.c_str());
    }
    std::string where = where_in_file(message, file);
    if (where.empty()) where = where_in_file(message, path);
    // Short: an ack's text has 127 characters, and the path comes last.
    loaded->refusal = rejected + "invalid " + file_kind(command.kind) + " file" + (where.empty() ? "" : " (" + where + ")") +
                      ": '" + path + "'";
    loaded->law.reset();
  }
  return loaded;
}

CommandReply ServoDaemon::finish_load(Loaded& loaded) {
  using Kind = servo::CommandKind;
  const servo::Command& command = loaded.command;
  if (!loaded.refusal.empty()) return {command.sequence, false, loaded.refusal, command.client};
  CommandReply reply{command.sequence, false, "", command.client};
  switch (command.kind) {
    case Kind::kRunProgram:
      reply = post_program(command, &loaded.program);
      break;
    case Kind::kLoadFeedforward:
      reply = queue(command);
      if (reply.accepted) set_loaded_file(LoadedFileSlot::kFeedforward, loaded.canonical, loaded.sha256);
      break;
    case Kind::kLoadCalibration:
    case Kind::kLoadModel: {
      const servo::CommutationMode mode = loaded.law->mode;
      if (!cycle_->law_handover(mode).post(loaded.law->law.get())) {
        reply.text = "rejected: an earlier load is still waiting for standstill";
        break;
      }
      laws_.push_back(std::move(loaded.law));
      reply = {command.sequence, true, "loaded; swapped in at the next standstill"};
      break;
    }
    default:
      reply.text = "unknown command";
      break;
  }
  reply.client = command.client;
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

namespace {

// A seqlock's payload is read while it may be written: every byte goes
// through std::atomic_ref (relaxed), so the race is on atomics, not UB; the
// generation counter says whether the copy is whole.
static_assert(std::is_trivially_copyable_v<telemetry::LoadedFileText>);
void atomic_copy(unsigned char* to, const unsigned char* from, std::size_t bytes, bool to_shared) noexcept {
  for (std::size_t i = 0; i < bytes; ++i) {
    if (to_shared) {
      std::atomic_ref<unsigned char>(to[i]).store(from[i], std::memory_order_relaxed);
    } else {
      to[i] = std::atomic_ref<unsigned char>(const_cast<unsigned char&>(from[i])).load(std::memory_order_relaxed);
    }
  }
}

}  // namespace

void ServoDaemon::set_loaded_file(LoadedFileSlot slot, const std::string& path, const std::string& sha256) noexcept {
  FileSlot& file = files_[static_cast<std::size_t>(slot)];
  telemetry::LoadedFileText text;  // this thread is the only writer: its own reads need no care
  text.path.assign(path);
  text.sha256.assign(sha256);
  telemetry::LoadedFileText current;
  atomic_copy(reinterpret_cast<unsigned char*>(&current), reinterpret_cast<const unsigned char*>(&file.text),
              sizeof current, false);
  if (current.path.view() == text.path.view() && current.sha256.view() == text.sha256.view()) return;
  const std::uint64_t generation = file.generation.load(std::memory_order_relaxed);
  file.generation.store(generation + 1, std::memory_order_relaxed);  // odd: being written
  std::atomic_thread_fence(std::memory_order_release);
  atomic_copy(reinterpret_cast<unsigned char*>(&file.text), reinterpret_cast<const unsigned char*>(&text), sizeof text,
              true);
  file.generation.store(generation + 2, std::memory_order_release);
}

std::uint64_t ServoDaemon::loaded_file(LoadedFileSlot slot, telemetry::LoadedFileText& out) const noexcept {
  const FileSlot& file = files_[static_cast<std::size_t>(slot)];
  for (int attempt = 0; attempt < 8; ++attempt) {
    const std::uint64_t before = file.generation.load(std::memory_order_acquire);
    if (before % 2 != 0) continue;
    atomic_copy(reinterpret_cast<unsigned char*>(&out), reinterpret_cast<const unsigned char*>(&file.text), sizeof out,
                false);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (file.generation.load(std::memory_order_relaxed) == before) return before;
  }
  // Being rewritten on every look: say so rather than report a torn name.
  out.path.assign("(changing)");
  out.sha256.assign("");
  return 0;
}

void ServoDaemon::update_law_files() noexcept {
  const std::pair<servo::CommutationMode, LoadedFileSlot> slots[] = {
      {servo::CommutationMode::kClassical, LoadedFileSlot::kCalibration},
      {servo::CommutationMode::kPgnn, LoadedFileSlot::kPgnnModel},
      {servo::CommutationMode::kSpline, LoadedFileSlot::kSplineModel},
  };
  for (const auto& [mode, slot] : slots) {
    for (const auto& law : laws_) {
      if (law->mode == mode && cycle_->law_handover(mode).is_current(law->law.get())) {
        set_loaded_file(slot, law->source, law->sha256);
      }
    }
  }
}

void ServoDaemon::mirror_state() noexcept { state_seen_.store(cycle_->state(), std::memory_order_release); }

void ServoDaemon::drain_commands() noexcept {
  using Kind = servo::CommandKind;
  servo::Command command;
  while (commands_->try_pop(command)) {
    servo::CommandStatus status = servo::CommandStatus::kAccepted;
    const bool was_pending = cycle_->mode_change_pending();
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
