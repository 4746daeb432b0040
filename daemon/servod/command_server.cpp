#include "daemon/servod/command_server.hpp"

#include <chrono>
#include <cmath>
#include <exception>
#include <stdexcept>
#include <vector>

#include "config/yaml_reader.hpp"
#include "daemon/servod/feedforward_file.hpp"

namespace clm::servod {
namespace {

using telemetry::CommandKind;

// collect_garbage about every 100 passes (0.2 s at the default poll period).
constexpr std::int64_t kGarbagePasses = 100;

std::string check_positive(const char* field, double value) {
  if (value > 0.0) return "";
  return std::string("move_to: ") + field + " must be positive, got " + std::to_string(value);
}

}  // namespace

std::string to_daemon_command(const telemetry::ServoCommand& command, DaemonCommand& out) {
  using Kind = DaemonCommand::Kind;
  DaemonCommand result;
  result.sequence = command.sequence;
  switch (command.command) {
    case CommandKind::kEnable: result.kind = Kind::kEnable; break;
    case CommandKind::kDisable: result.kind = Kind::kDisable; break;
    case CommandKind::kClearFault: result.kind = Kind::kClearFault; break;
    case CommandKind::kStop: result.kind = Kind::kStop; break;
    case CommandKind::kMoveTo: {
      for (const auto& reason : {check_positive("velocity_m_per_s", command.velocity_m_per_s),
                                 check_positive("acceleration_m_per_s2", command.acceleration_m_per_s2),
                                 check_positive("jerk_m_per_s3", command.jerk_m_per_s3)}) {
        if (!reason.empty()) return reason;
      }
      result.kind = Kind::kMoveTo;
      result.target_m = command.target_m;
      result.limits = {command.velocity_m_per_s, command.acceleration_m_per_s2, command.jerk_m_per_s3};
      break;
    }
    case CommandKind::kRunProgram:
      result.kind = Kind::kRunProgram;
      result.path = std::string(command.program.view());
      break;
    case CommandKind::kSetCommutation:
      // The codes are those of servo::CommutationMode (lcmtypes/servo_state_t.lcm).
      if (command.commutation < 0 || command.commutation >= static_cast<int>(servo::CommutationMode::kExperiment)) {
        return "set_commutation: mode " + std::to_string(command.commutation) +
               " is not a commutation law (0 original .. 4 oracle); experiments use set_experiment";
      }
      result.kind = Kind::kSetCommutation;
      result.mode = static_cast<servo::CommutationMode>(command.commutation);
      break;
    case CommandKind::kSetExperiment:
      result.kind = Kind::kSetExperiment;
      result.mode = servo::CommutationMode::kExperiment;
      result.coil_set = command.coil_set;
      result.delta_rad = command.delta_rad;
      break;
    case CommandKind::kLoadCalibration:
      result.kind = Kind::kLoadCalibration;
      result.mode = servo::CommutationMode::kClassical;
      result.path = std::string(command.path.view());
      break;
    case CommandKind::kLoadModel: {
      // servo_command_t has no mode field: the model file's own `kind:`
      // says which law it replaces.
      result.kind = Kind::kLoadModel;
      result.path = std::string(command.path.view());
      std::string kind;
      try {
        kind = yaml::Node::load_file(result.path)["kind"].as_string();
      } catch (const std::exception& e) {
        return std::string("load_model: ") + e.what();
      }
      if (kind == "pgnn") {
        result.mode = servo::CommutationMode::kPgnn;
      } else if (kind == "spline") {
        result.mode = servo::CommutationMode::kSpline;
      } else {
        return "load_model: " + result.path + ": kind: expected pgnn or spline, got '" + kind + "'";
      }
      break;
    }
    case CommandKind::kLoadFeedforward: {
      // Read and checked here, off the cycle; the cycle only receives the
      // three parameters through its command queue.
      result.kind = Kind::kSetFeedforward;
      result.path = std::string(command.path.view());
      try {
        result.feedforward = load_feedforward_file(result.path).parameters;
      } catch (const std::exception& e) {
        return std::string("load_feedforward: ") + e.what();
      }
      const auto& ff = result.feedforward;
      for (const auto& [key, value] : {std::pair{"mass_kg", ff.mass_kg}, std::pair{"viscous_N_s_per_m", ff.viscous_N_s_per_m},
                                       std::pair{"coulomb_N", ff.coulomb_N}}) {
        if (!std::isfinite(value)) return "load_feedforward: " + result.path + ": " + key + " is not a finite number";
      }
      break;
    }
    default:
      return "unknown command " + std::to_string(static_cast<int>(command.command));
  }
  out = std::move(result);
  return "";
}

bool answered_by_cycle(DaemonCommand::Kind kind) noexcept {
  using Kind = DaemonCommand::Kind;
  switch (kind) {
    case Kind::kEnable:
    case Kind::kDisable:
    case Kind::kClearFault:
    case Kind::kStop:
    case Kind::kSetCommutation:
    case Kind::kSetExperiment:
    case Kind::kSetFeedforward:
      return true;
    default:
      return false;
  }
}

CommandServer::CommandServer(telemetry::TelemetryPublisher& publisher, ServoDaemon& daemon, double poll_period_s)
    : publisher_(publisher), daemon_(daemon), poll_period_s_(poll_period_s) {
  if (!(poll_period_s > 0.0)) throw std::invalid_argument("CommandServer: poll_period_s must be positive");
}

CommandServer::~CommandServer() { stop(); }

void CommandServer::start() {
  if (thread_.joinable()) throw std::logic_error("CommandServer::start: already running");
  stop_requested_.store(false, std::memory_order_release);
  thread_ = std::thread([this] {
    const auto pause = std::chrono::duration<double>(poll_period_s_);
    while (!stop_requested_.load(std::memory_order_acquire)) {
      if (serve_once() == 0) std::this_thread::sleep_for(pause);
    }
  });
}

void CommandServer::stop() {
  stop_requested_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

int CommandServer::serve_once() {
  int acks = 0;
  const auto ack = [&](std::int64_t sequence, bool accepted, const std::string& text) {
    try {
      publisher_.publish_ack(sequence, accepted, text);
    } catch (const std::exception&) {
      // LCM refused the ack: the sender times out; the daemon goes on.
    }
    ++acks;
  };
  telemetry::ServoCommand received;
  while (publisher_.poll_command(received)) {
    served_.fetch_add(1, std::memory_order_relaxed);
    DaemonCommand command;
    const std::string reason = to_daemon_command(received, command);
    if (!reason.empty()) {
      ack(received.sequence, false, "rejected: " + reason);
      continue;
    }
    const CommandReply reply = daemon_.submit(command);
    // A queued command is acked once, with the cycle's decision (below).
    if (!(reply.accepted && answered_by_cycle(command.kind))) ack(reply.sequence, reply.accepted, reply.text);
  }
  for (const CommandReply& reply : daemon_.take_replies()) ack(reply.sequence, reply.accepted, reply.text);
  if (++passes_ % kGarbagePasses == 0) daemon_.collect_garbage();
  return acks;
}

}  // namespace clm::servod
