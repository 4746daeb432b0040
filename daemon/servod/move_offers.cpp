#include "daemon/servod/move_offers.hpp"

#include <algorithm>
#include <stdexcept>

namespace clm::servod {

servo::AxisSnapshot MoveOffers::snapshot(servo::ServoState state, bool parameter_change_pending) const {
  servo::AxisSnapshot axis;
  axis.state = state;
  axis.at_rest = mailbox_->at_rest();
  axis.restricted = mailbox_->restricted();
  axis.hold_position_m = mailbox_->hold_position_m();
  axis.parameter_change_pending = parameter_change_pending;
  axis.jog_running = mailbox_->jogging() || mailbox_->jog_pending();
  axis.jog_velocity_m_per_s = jog_velocity_m_per_s_;
  axis.jog_limits = jog_limits_;
  return axis;
}

MoveOffers::Outcome MoveOffers::post(const servo::Command& command, const servo::ServoSettings& settings,
                                     const servo::AxisSnapshot& axis, const servo::ProgramSteps& program) {
  using Result = servo::CommandResult;
  servo::MoveDecision decision = servo::decide_move(settings, axis, command, program);
  if (decision.result == Result::kJogging) {
    // A repeat of the running jog: a renewal that comes after the cycle began
    // its stop is refused, so the answer never says jogging of a jog that stops.
    return {mailbox_->jog_pending() || mailbox_->renew_jog() ? Result::kJogging : Result::kRejectedJogStopping, ""};
  }
  if (!decision.program) return {decision.result, std::move(decision.detail)};
  auto move = std::make_unique<control::MoveProgram>(std::move(*decision.program));
  // The command goes to the cycle's queue before its program is offered, so
  // the loop knows whom to answer when the cycle takes the offer or drops it.
  // No offer is pending (decide_move saw the axis at rest), so this one is
  // the cycle's next.
  servo::Command posted = command;
  posted.offer = mailbox_->offers_decided() + 1;
  if (!commands_->try_push(posted)) return {Result::kRejectedQueueFull, ""};
  const bool jog = command.kind == servo::CommandKind::kJog;
  if (!(jog ? mailbox_->post_jog(move.get()) : mailbox_->post_program(move.get()))) {
    throw std::logic_error("a program was offered while another was pending");
  }
  programs_.push_back(std::move(move));
  if (jog) {
    jog_velocity_m_per_s_ = command.jog_velocity_m_per_s;
    jog_limits_ = command.limits;
  }
  return {Result::kQueued, ""};
}

void MoveOffers::collect_garbage() {
  std::erase_if(programs_, [&](const std::unique_ptr<control::MoveProgram>& program) {
    return !mailbox_->program_in_use(program.get());
  });
}

}  // namespace clm::servod
