#pragma once
// What crosses between the servo cycle's thread and its owner's threads,
// and nothing else: the objects the owner offers (move programs, jogs,
// commutation laws: Handover slots), the jog's renewals, and the few facts a
// planner needs of the cycle (at rest, the hold position, restricted mode,
// how many offers it has decided). Every member is lock-free; the owner's
// side may be called from any non-real-time thread, the cycle's side
// (ServoCycle, a friend) only from the loop.

#include <array>
#include <atomic>
#include <cstdint>

#include "commutation/commutator.hpp"
#include "daemon/control/trajectory.hpp"
#include "daemon/servo/cycle_record.hpp"
#include "daemon/servo/handover.hpp"

namespace clm::servo {

class CycleMailbox {
 public:
  /// Offer a move program: the cycle starts it at its next cycle if it is
  /// enabled, idle and at the program's start (within 1 µm), else drops it.
  /// Either way offers_decided() counts it and the cycle's status says which
  /// (CycleStatus::last_offer_result). False if an earlier offer is pending.
  bool post_program(const control::MoveProgram* program) noexcept { return program_.post(program); }
  /// Offer a jog: a program the cycle runs like any other but stops along
  /// its stop limits when renew_jog() has not been called for jog_timeout_s.
  /// False if an earlier offer is still pending.
  bool post_jog(const control::MoveProgram* jog) noexcept {
    if (program_.pending()) return false;
    jog_offer_.store(jog, std::memory_order_release);
    jog_token_.store(0, std::memory_order_release);
    return program_.post(jog);
  }
  /// Keeps the running jog going; false when no jog runs or the cycle has
  /// already begun its stop (then the jog is over: post a new one).
  bool renew_jog() noexcept {
    if (!jogging_.load(std::memory_order_acquire)) return false;
    std::int64_t token = jog_token_.load(std::memory_order_acquire);
    while (token != kJogStopped) {
      if (jog_token_.compare_exchange_weak(token, token + 1, std::memory_order_acq_rel)) return true;
    }
    return false;
  }
  /// A jog runs and has not been stopped.
  bool jogging() const noexcept { return jogging_.load(std::memory_order_acquire); }
  /// A jog was offered and the cycle has not taken it yet; it starts with a
  /// fresh jog_timeout_s when it does.
  bool jog_pending() const noexcept {
    return jog_offer_.load(std::memory_order_acquire) != nullptr && program_.pending();
  }
  /// No program, jog or stop under way and none offered.
  bool at_rest() const noexcept { return idle_.load(std::memory_order_acquire) && !program_.pending(); }
  /// The cycle may still use `program` (it must not be freed).
  bool program_in_use(const control::MoveProgram* program) const noexcept { return program_.in_use(program); }
  /// Offers decided so far (taken or dropped).
  std::int64_t offers_decided() const noexcept { return offers_decided_.load(std::memory_order_acquire); }
  /// Position the axis holds when idle [m] (for planning a move from it).
  double hold_position_m() const noexcept { return hold_position_m_.load(std::memory_order_acquire); }
  /// Restricted mode (enabled outside the soft limits after
  /// kPositionOutOfRange): only a move back inside at reduced speed starts.
  bool restricted() const noexcept { return restricted_.load(std::memory_order_acquire); }
  /// Offer a new law for `mode`: the cycle adopts it at the next standstill.
  Handover<CommutationLaw>& law(CommutationMode mode) noexcept { return laws_[static_cast<std::size_t>(mode)]; }
  const Handover<CommutationLaw>& law(CommutationMode mode) const noexcept {
    return laws_[static_cast<std::size_t>(mode)];
  }

 private:
  friend class ServoCycle;
  // Jog renewals are counted in jog_token_ (kJogStopped once the cycle stops
  // the jog), so that a renewal and the cycle's decision to stop never cross.
  static constexpr std::int64_t kJogStopped = -1;

  Handover<control::MoveProgram> program_;
  std::array<Handover<CommutationLaw>, kCommutationModes> laws_;
  std::atomic<const control::MoveProgram*> jog_offer_{nullptr};
  std::atomic<std::int64_t> jog_token_{kJogStopped};
  std::atomic<bool> jogging_{false};
  std::atomic<std::int64_t> offers_decided_{0};
  std::atomic<bool> idle_{true};
  std::atomic<bool> restricted_{false};
  std::atomic<double> hold_position_m_{0.0};
};

}  // namespace clm::servo
