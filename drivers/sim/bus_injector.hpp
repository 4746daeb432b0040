#pragma once
// Bus-side fault injection for the simulated drive and force sensor on a real
// bus (`clm sim --can IFACE --inject PLAN`, docs/reliability.md): a plan of
// steps, each fired on request at the next SYNC while the axis is enabled
// (the daemon's last RPDO1 had ControlEnable set), acting on the replies the
// nodes (SimulatedNodes) produced for that SYNC and the following ones. What
// it does to a frame is what a faulty node or bus would do to it: lose it,
// send it late, corrupt it, send it twice. No allocation per frame. The
// drive's latch frame (TPDO2) is never touched: it goes out at once, before
// the drive feedback, as the nodes made it.
//
// The in-process bus of the daemon's cycle tests has its own, finer injection
// (in_process_bus.hpp); this one is for separate processes over SocketCAN.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "drivers/can/can_protocol.hpp"

namespace clm::sim {

enum class InjectionKind {
  kDropDrive,        ///< the drive's TPDO1 is not sent
  kDropForce,        ///< the force sensor's TPDO1 is not sent
  kLateDrive,        ///< the drive's TPDO1 is sent `late_fraction` of a period after SYNC
  kCorruptReserved,  ///< a reserved status bit (bit 7) is set in the drive's TPDO1
  kCorruptAlive,     ///< the drive's alive counter is advanced by 7 (one frame)
  kCorruptForceAlive,  ///< the force sensor's alive counter is advanced by 7 (one frame)
  kCorruptPosition,  ///< bit 29 of the drive's position is flipped (a 0.537 m jump)
  kWrongDlc,         ///< the drive's TPDO1 goes out with DLC 6 instead of 7
  kDuplicate,        ///< the drive's TPDO1 is sent twice
  kDriveFault,       ///< the drive latches a fault of its own (the current stops)
  kPush,             ///< `value` newtons against the translator's motion for `frames` SYNCs, ended early
                     ///< when the drive is disabled (the fixture lets go); no frame is touched
};

/// Name in a plan: "drop-drive", "drop-force", "late-drive", "corrupt-reserved",
/// "corrupt-alive", "corrupt-force-alive", "corrupt-position", "wrong-dlc",
/// "duplicate", "drive-fault",
/// "push" (written push:N:F, F newtons > 0).
const char* name(InjectionKind kind) noexcept;

struct InjectionStep {
  InjectionKind kind = InjectionKind::kDropDrive;
  int frames = 1;  ///< consecutive SYNCs the step acts on, 1 … 1000
  double value = 0.0;  ///< push: the force [N]
};

/// Parses "drop-drive:3,late-drive:1,drive-fault,push:30:700" (":N" defaults
/// to 1). Throws std::invalid_argument naming the item for an unknown kind, a
/// count outside 1 … 1000, a push without a force > 0 or a value on another kind.
std::vector<InjectionStep> parse_injection_plan(const std::string& plan);

class BusInjector {
 public:
  BusInjector(const can::ProtocolConfig& protocol, std::vector<InjectionStep> plan);

  /// Requests the next step of the plan; it fires at the first SYNC at which
  /// the axis is enabled. Requests beyond the plan are ignored (counted).
  void request_next() noexcept;

  /// A frame from the daemon (the nodes' receive filter: SYNC and RPDOs);
  /// RPDO1 tells whether the axis is enabled.
  void observe(const can::Frame& frame) noexcept;

  /// Called on a SYNC before the nodes reply: returns the step that fires at
  /// this SYNC, or nullptr. For kDriveFault the caller latches the drive's
  /// fault before the nodes reply, so this SYNC's feedback already shows it;
  /// for kPush the caller sets the motor's disturbance force and removes it
  /// when push_active() turns false or the drive is disabled.
  const InjectionStep* on_sync() noexcept;

  struct Replies {
    std::array<can::Frame, 4> now{};  ///< send at once, in order: latch, drive (twice if duplicated), force
    std::size_t now_count = 0;
    std::array<can::Frame, 2> late{};  ///< send `late_fraction` of a period after the SYNC
    std::size_t late_count = 0;
  };
  /// The nodes' replies to this SYNC as the injection makes them.
  void transform(std::span<const can::Frame> replies, Replies& out) const noexcept;

  /// Index (0-based) of the step that acts now or acted last; −1 before the first.
  int step_index() const noexcept { return fired_ - 1; }
  /// A push step acts on this SYNC.
  bool push_active() const noexcept;
  int steps_fired() const noexcept { return fired_; }
  int requests_ignored() const noexcept { return requests_ignored_; }
  bool axis_enabled() const noexcept { return axis_enabled_; }

  /// Share of the period after SYNC at which a late frame is sent: past the
  /// daemon's default receive window (0.5) and before the next SYNC.
  static constexpr double kLateFraction = 0.8;

 private:
  can::ProtocolConfig protocol_;
  std::vector<InjectionStep> plan_;
  int fired_ = 0;           ///< steps fired so far
  int pending_requests_ = 0;
  int requests_ignored_ = 0;
  int remaining_ = 0;       ///< SYNCs the active step still acts on (this one included)
  bool acting_ = false;     ///< the active step acts on this SYNC's replies
  bool axis_enabled_ = false;
};

}  // namespace clm::sim
