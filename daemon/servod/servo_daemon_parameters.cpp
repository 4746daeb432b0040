// The run-time parameters of ServoDaemon (docs/servod.md, "Run-time
// parameters"): get answers from the values the cycle uses; set validates a
// change as the configuration would, refuses while the axis moves, and hands
// the whole tuning to the cycle through its command queue; the cycle's answer
// commits it. Moves are planned against the committed values, and refused
// while a change is on its way, so that no move is ever checked against
// limits the cycle does not have.
#include "daemon/servod/servo_daemon.hpp"

namespace clm::servod {

RuntimeValues ServoDaemon::runtime_values() const {
  std::lock_guard lock(runtime_mutex_);
  return runtime_;
}

bool ServoDaemon::parameter_change_pending() const {
  std::lock_guard lock(runtime_mutex_);
  return runtime_pending_.has_value();
}

servo::ServoSettings ServoDaemon::planning_settings() const {
  servo::ServoSettings settings = config_.servo;
  std::lock_guard lock(runtime_mutex_);
  settings.apply(runtime_.tuning);
  return settings;
}

CommandReply ServoDaemon::get_parameter(const servo::Command& command) const {
  const RuntimeParameter* parameter = find_runtime_parameter(command.parameter.view());
  if (parameter == nullptr) {
    return {command.sequence, command.client, servo::CommandResult::kRejectedInvalid,
            "unknown parameter '" + std::string(command.parameter.view()) + "' (docs/servod.md)"};
  }
  const RuntimeValues values = runtime_values();
  return {command.sequence, command.client, servo::CommandResult::kAccepted,
          describe_parameter(*parameter, parameter_value(values, *parameter))};
}

CommandReply ServoDaemon::set_parameter(servo::Command& command) {
  // At rest only: the command table (servo::check_legal, in submit).
  std::lock_guard lock(runtime_mutex_);
  if (runtime_pending_) return {command.sequence, command.client, servo::CommandResult::kRejectedParameterPending};
  const ParameterChange change =
      change_parameter(runtime_, config_.servo, config_.loop.rate_hz, command.parameter.view(), command.value);
  if (!change.values) return {command.sequence, command.client, servo::CommandResult::kRejectedInvalid, change.refusal};
  command.tuning = change.values->tuning;
  CommandReply reply = queue(command);
  if (reply.accepted()) {
    runtime_pending_ = change.values;
    runtime_pending_command_ = {command.sequence, command.client, servo::CommandResult::kAccepted};
  }
  return reply;
}

void ServoDaemon::settle_parameter_change(const RtReply& reply) {
  bool feedforward_changed = false;
  {
    std::lock_guard lock(runtime_mutex_);
    if (!runtime_pending_ || reply.sequence != runtime_pending_command_.sequence ||
        reply.client != runtime_pending_command_.client) {
      return;
    }
    if (reply.result == servo::CommandResult::kAccepted) {
      const auto& before = runtime_.tuning.feedforward;
      const auto& after = runtime_pending_->tuning.feedforward;
      feedforward_changed = before.mass_kg != after.mass_kg || before.viscous_N_s_per_m != after.viscous_N_s_per_m ||
                            before.coulomb_N != after.coulomb_N;
      runtime_ = *runtime_pending_;
    }
    runtime_pending_.reset();
  }
  // The status names the feedforward file only while its parameters are in use.
  if (feedforward_changed) set_loaded_file(LoadedFileSlot::kFeedforward, "", "");
}

}  // namespace clm::servod
