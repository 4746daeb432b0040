#include "daemon/servod/parameter_store.hpp"

namespace clm::servod {

RuntimeValues ParameterStore::values() const {
  std::lock_guard lock(mutex_);
  return values_;
}

bool ParameterStore::change_pending() const {
  std::lock_guard lock(mutex_);
  return pending_.has_value();
}

servo::ServoSettings ParameterStore::planning_settings() const {
  servo::ServoSettings settings = base_;
  std::lock_guard lock(mutex_);
  settings.apply(values_.tuning);
  return settings;
}

ParameterStore::Answer ParameterStore::get(std::string_view key) const {
  const RuntimeParameter* parameter = find_runtime_parameter(key);
  if (parameter == nullptr) {
    return {servo::CommandResult::kRejectedInvalid, "unknown parameter '" + std::string(key) + "' (docs/servod.md)"};
  }
  return {servo::CommandResult::kAccepted, describe_parameter(*parameter, parameter_value(values(), *parameter))};
}

ParameterStore::Answer ParameterStore::set(std::string_view key, double value, std::int64_t sequence,
                                           std::int64_t client,
                                           const std::function<servo::CommandResult(const servo::Tuning&)>& queue) {
  std::lock_guard lock(mutex_);
  if (pending_) return {servo::CommandResult::kRejectedParameterPending, ""};
  ParameterChange change = change_parameter(values_, base_, rate_hz_, plant_, key, value);
  if (!change.values) return {servo::CommandResult::kRejectedInvalid, change.refusal};
  const servo::CommandResult queued = queue(change.values->tuning);
  if (servo::is_accepted(queued)) {
    pending_ = std::move(change.values);
    pending_sequence_ = sequence;
    pending_client_ = client;
  }
  return {queued, ""};
}

bool ParameterStore::settle(std::int64_t sequence, std::int64_t client, servo::CommandResult result) {
  std::lock_guard lock(mutex_);
  if (!pending_ || sequence != pending_sequence_ || client != pending_client_) return false;
  bool feedforward_changed = false;
  if (result == servo::CommandResult::kAccepted) {
    const auto& before = values_.tuning.feedforward;
    const auto& after = pending_->tuning.feedforward;
    feedforward_changed = before.mass_kg != after.mass_kg || before.viscous_N_s_per_m != after.viscous_N_s_per_m ||
                          before.coulomb_N != after.coulomb_N;
    values_ = *pending_;
  }
  pending_.reset();
  return feedforward_changed;
}

void ParameterStore::set_feedforward(const control::FeedforwardParameters& feedforward) {
  std::lock_guard lock(mutex_);
  values_.tuning.feedforward = feedforward;
}

}  // namespace clm::servod
