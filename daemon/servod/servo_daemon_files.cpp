// ServoDaemon's files: the laws built from calibration and model files, the
// files commands name (read through the file policy, on the loader thread
// when there is one; refusals name the path and the place, never the
// content), and the status's loaded-file slots (a seqlock read byte by byte
// through atomics). The command path is in servo_daemon.cpp.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <span>
#include <type_traits>
#include <vector>

#include "commutation/law_check.hpp"
#include "commutation/range_blend.hpp"
#include "config/regular_file.hpp"
#include "config/sha256.hpp"
#include "daemon/servod/feedforward_file.hpp"
#include "daemon/servod/servo_daemon_parts.hpp"

namespace clm::servod {
namespace {

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

/// A law its file describes well but that the loop cannot afford or that no
/// motor has (commutation/law_check.hpp). `reason` is describe()'s numbers
/// and coil set, never text of the file: it may go into an ack.
class LawRefused : public std::runtime_error {
 public:
  LawRefused(const std::string& path, const std::string& what, const std::string& why)
      : std::runtime_error(path + ": " + what + ": " + why), reason(why) {}
  std::string reason;
};

/// Throws LawRefused naming `path` unless `check` accepted the law.
void require_accepted(const LawCheck& check, const std::string& path, const std::string& what) {
  if (!check.accepted()) throw LawRefused(path, what, describe(check));
}

/// What a model law blends to outside its identified range
/// (commutation/range_blend.hpp; docs/servod.md, "What a law may cost and
/// mean"): the calibration loaded last (the classical law's, in use or
/// waiting for standstill), else the drive's own constants (the original
/// law's). `laws` is ServoDaemon::laws_, read on the thread that owns it.
template <class Laws>
std::vector<ClassicalEstimate> blend_target(const Laws& laws) {
  for (const auto mode : {servo::CommutationMode::kClassical, servo::CommutationMode::kOriginal}) {
    for (auto law = laws.rbegin(); law != laws.rend(); ++law) {
      if ((*law)->mode == mode) return (*law)->estimates;
    }
  }
  return {};
}

/// The drive's own constants for every coil set: the original law's, and the
/// blend target when no calibration is loaded.
std::vector<ClassicalEstimate> drive_estimates(const ServodConfig& config) {
  return std::vector<ClassicalEstimate>(static_cast<std::size_t>(config.motor.coil_sets),
                                        {config.motor.drive.motor_constant_N_per_A, config.motor.drive.phase_offset_rad});
}

/// The law of `model` as the daemon uses it (RangeBlendedCommutator to
/// `outside`), checked on the whole stroke; throws LawRefused naming `path`.
std::unique_ptr<CommutationLaw> blended_model_law(const ElectromagneticModel& model,
                                                  std::span<const ClassicalEstimate> outside,
                                                  const ServodConfig& config, const std::string& path,
                                                  const std::string& what) {
  auto law = std::make_unique<RangeBlendedCommutator>(model, outside, config.motor.drive, config.commutation.options);
  require_accepted(check_blended_law(model, outside, law_limits(config)), path, what);
  return law;
}

bool same_estimates(std::span<const ClassicalEstimate> a, std::span<const ClassicalEstimate> b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](const ClassicalEstimate& x, const ClassicalEstimate& y) {
    return x.motor_constant_N_per_A == y.motor_constant_N_per_A && x.phase_offset_rad == y.phase_offset_rad;
  });
}

}  // namespace

std::string ServoDaemon::law_source(servo::CommutationMode mode) const {
  // The law the cycle uses now; one still waiting for standstill is not it.
  for (const auto& law : laws_) {
    if (law->mode == mode && cycle_->mailbox().law(mode).is_current(law->law.get())) return law->source;
  }
  for (const ExtraLaw& extra : extra_laws_) {
    if (extra.mode == mode && cycle_->mailbox().law(mode).is_current(extra.law)) return extra.source;
  }
  return "";
}

namespace {

/// Throws naming `path` when its positions are in another frame than the
/// axis's (docs/servod.md, "Homing").
void require_same_reference(const EncoderReference& recorded, const ServodConfig& config, const std::string& path) {
  const EncoderReference axis = encoder_reference(config);
  if (!recorded.same_frame(axis)) {
    throw std::runtime_error(path + ": encoder_reference: made against " + recorded.describe() +
                             "; this axis homes to " + axis.describe() + " (homing: in " + config.origin + ")");
  }
}

}  // namespace

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
    require_same_reference(owned->calibration.reference, config_, path);
    owned->estimates = owned->calibration.estimates();
    owned->law = std::make_unique<ClassicalCommutator>(owned->estimates, config_.motor.pole_pitch_m, config_.motor.drive,
                                                       config_.commutation.options.phase_convention);
    require_accepted(check_classical_law(owned->estimates, law_limits(config_)), path, "calibration");
  } else {
    owned->model = parse_model_file(yaml::Node::load_string(text, path));
    check_matches_motor(owned->model.model, config_.motor, path, config_.motor_file);
    require_same_reference(owned->model.reference, config_, path);
    const ModelKind expected = mode == servo::CommutationMode::kPgnn ? ModelKind::kPgnn : ModelKind::kSpline;
    if (owned->model.model.kind != expected) {
      throw std::runtime_error(path + ": kind: the file holds a " +
                               std::string(owned->model.model.kind == ModelKind::kPgnn ? "pgnn" : "spline") +
                               " model, the " + servo::name(mode) + " commutation needs a " +
                               (expected == ModelKind::kPgnn ? "pgnn" : "spline") + " model");
    }
    // The blend target: on the thread that owns laws_ (start-up, or a load
    // without a loader thread) the one blend_target decides; on the loader
    // thread the drive's own for now, and finish_load sets it.
    owned->estimates = loader_ == nullptr ? blend_target(laws_) : drive_estimates(config_);
    owned->law = blended_model_law(owned->model.model, owned->estimates, config_, path,
                                   std::string(servo::name(mode)) + " model");
  }
  return owned;
}

std::unique_ptr<ServoDaemon::Loaded> ServoDaemon::load(const servo::Command& command) const {
  using Kind = servo::CommandKind;
  auto loaded = std::make_unique<Loaded>();
  loaded->command = command;
  const std::string path(servo::file_named(command));
  const std::string what = std::string(servo::route(command.kind).name) + ": ";
  const char* file_kind = servo::route(command.kind).file_kind;
  const std::string refusal = check_loadable(file_policy_, path, loaded->canonical);
  if (!refusal.empty()) {
    // The rule first, the path last: an ack's text is short, a long path is cut.
    const std::string quoted = "'" + path + "': ";
    loaded->refusal = refusal.compare(0, quoted.size(), quoted) == 0
                          ? what + refusal.substr(quoted.size()) + ": '" + path + "'"
                          : what + refusal;
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
        loaded->refusal = what + "not a command that loads a file";
        break;
    }
  } catch (const std::exception& e) {
    // The parser's message may quote the file: in full to the log only.
    const std::string message = e.what();
    if (log_) {
      log_("refused " + std::string(file_kind) + " file '" + path + "': " + message);
    } else {
      std::fprintf(stderr, "clm-servod: refused %s file '%s': %s\n", file_kind, path.c_str(),
                   message.c_str());
    }
    std::string where = where_in_file(message, file);
    if (where.empty()) where = where_in_file(message, path);
    // Short: an ack's text has 127 characters, and the path comes last.
    if (const auto* refused = dynamic_cast<const LawRefused*>(&e)) {
      loaded->refusal = what + refused->reason + ": '" + path + "'";
    } else {
      loaded->refusal = what + "invalid " + file_kind + " file" + (where.empty() ? "" : " (" + where + ")") +
                        ": '" + path + "'";
    }
    loaded->law.reset();
  }
  return loaded;
}

CommandReply ServoDaemon::finish_load(Loaded& loaded) {
  using Kind = servo::CommandKind;
  using Result = servo::CommandResult;
  const servo::Command& command = loaded.command;
  if (!loaded.refusal.empty()) return reply_to(command, Result::kRejectedFile, loaded.refusal);
  switch (command.kind) {
    case Kind::kRunProgram:
      return post_move(command, {loaded.program.start_m, loaded.program.steps});
    case Kind::kLoadFeedforward: {
      CommandReply reply = queue(command);
      if (reply.accepted()) set_loaded_file(LoadedFileSlot::kFeedforward, loaded.canonical, loaded.sha256);
      return reply;
    }
    case Kind::kLoadCalibration:
    case Kind::kLoadModel: {
      const servo::CommutationMode mode = loaded.law->mode;
      if (command.kind == Kind::kLoadModel) {
        // Built on the loader thread without the calibration in use: blend to it now.
        OwnedLaw& owned = *loaded.law;
        const std::vector<ClassicalEstimate> target = blend_target(laws_);
        if (!same_estimates(owned.estimates, target)) {
          try {
            owned.law = blended_model_law(owned.model.model, target, config_, loaded.canonical,
                                          std::string(servo::name(mode)) + " model");
          } catch (const LawRefused& refused) {
            return reply_to(command, Result::kRejectedFile,
                            std::string(servo::route(command.kind).name) + ": " + refused.reason + ": '" +
                                std::string(servo::file_named(command)) + "'");
          }
          owned.estimates = target;
        }
      }
      if (!cycle_->mailbox().law(mode).post(loaded.law->law.get())) {
        return reply_to(command, Result::kRejectedLoadWaiting);
      }
      laws_.push_back(std::move(loaded.law));
      return reply_to(command, Result::kLoaded);
    }
    default:
      return reply_to(command, Result::kRejectedInvalid, "not a command that loads a file");
  }
}

namespace {

static_assert(std::is_trivially_copyable_v<telemetry::LoadedFileText>);
static_assert(std::atomic<std::uint64_t>::is_always_lock_free);

}  // namespace

void ServoDaemon::set_loaded_file(LoadedFileSlot slot, const std::string& path, const std::string& sha256) noexcept {
  FileSlot& file = files_[static_cast<std::size_t>(slot)];
  telemetry::LoadedFileText text;  // this thread is the only writer: its own reads need no care
  text.path.assign(path);
  text.sha256.assign(sha256);
  std::array<std::uint64_t, kLoadedFileWords> words{};  // the bytes beyond the text stay zero
  std::memcpy(words.data(), &text, sizeof text);
  bool same = true;
  for (std::size_t i = 0; i < words.size(); ++i) same = same && file.words[i].load(std::memory_order_relaxed) == words[i];
  if (same) return;
  const std::uint64_t generation = file.generation.load(std::memory_order_relaxed);
  file.generation.store(generation + 1, std::memory_order_relaxed);  // odd: being written
  std::atomic_thread_fence(std::memory_order_release);
  for (std::size_t i = 0; i < words.size(); ++i) file.words[i].store(words[i], std::memory_order_relaxed);
  file.generation.store(generation + 2, std::memory_order_release);
}

std::uint64_t ServoDaemon::loaded_file(LoadedFileSlot slot, telemetry::LoadedFileText& out) const noexcept {
  const FileSlot& file = files_[static_cast<std::size_t>(slot)];
  std::array<std::uint64_t, kLoadedFileWords> words;
  for (int attempt = 0; attempt < 8; ++attempt) {
    const std::uint64_t before = file.generation.load(std::memory_order_acquire);
    if (before % 2 != 0) continue;
    for (std::size_t i = 0; i < words.size(); ++i) words[i] = file.words[i].load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (file.generation.load(std::memory_order_relaxed) == before) {
      std::memcpy(static_cast<void*>(&out), words.data(), sizeof out);  // trivially copyable (asserted above)
      return before;
    }
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
      if (law->mode == mode && cycle_->mailbox().law(mode).is_current(law->law.get())) {
        set_loaded_file(slot, law->source, law->sha256);
      }
    }
  }
}

}  // namespace clm::servod
