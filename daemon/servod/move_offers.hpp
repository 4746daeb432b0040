#pragma once
// Moves, programs and jogs on their way from the command thread to the
// cycle: decided once (servo::decide_move, daemon/servo/move_decision.hpp)
// against the settings in use and the axis as the cycle reports it, then the
// command queued with the number of its offer, so that the loop knows whom
// to answer, and the program offered through the cycle's mailbox. Owns every
// program until the cycle no longer uses it. Command thread only.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "daemon/servo/command.hpp"
#include "daemon/servo/cycle_mailbox.hpp"
#include "daemon/servo/move_decision.hpp"
#include "daemon/telemetry/spsc_queue.hpp"

namespace clm::servod {

class MoveOffers {
 public:
  /// `mailbox` and `commands` (the cycle's command queue) must outlive this.
  MoveOffers(servo::CycleMailbox& mailbox, telemetry::SpscQueue<servo::Command>& commands)
      : mailbox_(&mailbox), commands_(&commands) {}

  /// The axis as decide_move sees it: `state` as the loop last mirrored it,
  /// the rest from the mailbox and the jog under way.
  servo::AxisSnapshot snapshot(servo::ServoState state, bool parameter_change_pending) const;

  struct Outcome {
    servo::CommandResult result = servo::CommandResult::kRejectedInvalid;
    std::string detail;  ///< a refusal's value and limit, where there is one
  };
  /// A move_to, run_program (`program`) or jog: kQueued when its program was
  /// offered (the cycle answers once it has taken it or said why not),
  /// kJogging for a repeat that renewed the running jog, else the refusal.
  Outcome post(const servo::Command& command, const servo::ServoSettings& settings, const servo::AxisSnapshot& axis,
               const servo::ProgramSteps& program = {});
  /// Frees the programs the cycle no longer uses.
  void collect_garbage();

 private:
  servo::CycleMailbox* mailbox_;
  telemetry::SpscQueue<servo::Command>* commands_;
  std::vector<std::unique_ptr<control::MoveProgram>> programs_;
  double jog_velocity_m_per_s_ = 0.0;  ///< of the last jog started
  control::MotionLimits jog_limits_{};  ///< of the last jog started
};

}  // namespace clm::servod
