#include "drivers/sim/bus_injector.hpp"

#include <algorithm>
#include <stdexcept>

#include "drivers/sim/injection_plan.hpp"

namespace clm::sim {
namespace {

constexpr std::array<InjectionKind, 11> kKinds{
    InjectionKind::kDropDrive,   InjectionKind::kDropForce,       InjectionKind::kLateDrive,
    InjectionKind::kCorruptReserved, InjectionKind::kCorruptAlive, InjectionKind::kCorruptForceAlive,
    InjectionKind::kCorruptPosition,
    InjectionKind::kWrongDlc,    InjectionKind::kDuplicate,       InjectionKind::kDriveFault,
    InjectionKind::kPush};

// Byte offsets in the drive's TPDO1 (docs/can-protocol.md).
constexpr std::size_t kPositionTopByte = 3;
constexpr std::size_t kStatusLowByte = 4;   // status bits 0..7
constexpr std::uint8_t kReservedStatusBit = 0x80;  // status bit 7, the lowest reserved one (kStatusReservedMask)
static_assert((clm::can::kStatusReservedMask & kReservedStatusBit) != 0);
constexpr std::size_t kAliveByte = 6;
// And in the force sensor's TPDO1.
constexpr std::size_t kForceAliveByte = 7;

}  // namespace

const char* name(InjectionKind kind) noexcept {
  switch (kind) {
    case InjectionKind::kDropDrive: return "drop-drive";
    case InjectionKind::kDropForce: return "drop-force";
    case InjectionKind::kLateDrive: return "late-drive";
    case InjectionKind::kCorruptReserved: return "corrupt-reserved";
    case InjectionKind::kCorruptAlive: return "corrupt-alive";
    case InjectionKind::kCorruptForceAlive: return "corrupt-force-alive";
    case InjectionKind::kCorruptPosition: return "corrupt-position";
    case InjectionKind::kWrongDlc: return "wrong-dlc";
    case InjectionKind::kDuplicate: return "duplicate";
    case InjectionKind::kDriveFault: return "drive-fault";
    case InjectionKind::kPush: return "push";
  }
  return "unknown";
}

std::vector<InjectionStep> parse_injection_plan(const std::string& plan) {
  std::vector<InjectionStep> steps;
  for (const PlanItem& item : parse_plan_items(plan)) {
    const auto kind = std::find_if(kKinds.begin(), kKinds.end(), [&](InjectionKind k) { return item.name == name(k); });
    if (kind == kKinds.end()) throw std::invalid_argument("injection plan: unknown step '" + item.text + "'");
    const bool push = *kind == InjectionKind::kPush;
    if (push != item.has_value || (push && !(item.value > 0.0))) {
      throw std::invalid_argument("injection plan: step '" + item.text + "': " +
                                  (push ? "a push is push:N:F with a force F > 0 N" : "takes no value"));
    }
    steps.push_back({*kind, item.count, item.value});
  }
  return steps;
}

BusInjector::BusInjector(const can::ProtocolConfig& protocol, std::vector<InjectionStep> plan)
    : protocol_(protocol), plan_(std::move(plan)) {}

void BusInjector::request_next() noexcept {
  if (fired_ + pending_requests_ >= static_cast<int>(plan_.size())) {
    ++requests_ignored_;
    return;
  }
  ++pending_requests_;
}

void BusInjector::observe(const can::Frame& frame) noexcept {
  if (frame.id == can::setpoint_id(protocol_, 0) && frame.dlc >= 1) {
    axis_enabled_ = (frame.data[0] & can::kControlEnable) != 0;
  }
}

const InjectionStep* BusInjector::on_sync() noexcept {
  acting_ = false;
  if (remaining_ > 0) {
    --remaining_;
    acting_ = true;
    return nullptr;  // the active step goes on
  }
  if (pending_requests_ == 0 || !axis_enabled_) return nullptr;
  --pending_requests_;
  const InjectionStep& step = plan_[static_cast<std::size_t>(fired_)];
  ++fired_;
  remaining_ = step.frames - 1;
  acting_ = true;
  return &step;
}

bool BusInjector::push_active() const noexcept {
  return acting_ && fired_ > 0 && plan_[static_cast<std::size_t>(fired_ - 1)].kind == InjectionKind::kPush;
}

void BusInjector::transform(std::span<const can::Frame> replies, Replies& out) const noexcept {
  out.now_count = out.late_count = 0;
  const bool active = acting_ && fired_ > 0;
  const InjectionKind kind = active ? plan_[static_cast<std::size_t>(fired_ - 1)].kind : InjectionKind::kDropDrive;
  const bool first = active && remaining_ == plan_[static_cast<std::size_t>(fired_ - 1)].frames - 1;
  const auto push_now = [&out](const can::Frame& frame) {
    if (out.now_count < out.now.size()) out.now[out.now_count++] = frame;
  };
  for (const can::Frame& reply : replies) {
    const bool drive = reply.id == can::drive_feedback_id(protocol_);
    const bool force = reply.id == can::force_feedback_id(protocol_);
    // Anything else, the drive's latch frame (TPDO2) included, is sent at
    // once and unchanged, in the nodes' order: the latch frame reaches the
    // daemon in its period, before the drive feedback (which a step may
    // drop, delay or corrupt, never move ahead of it).
    if (!active || !(drive || force)) {
      push_now(reply);
      continue;
    }
    if (force) {
      if (kind == InjectionKind::kDropForce) continue;
      can::Frame frame = reply;
      if (kind == InjectionKind::kCorruptForceAlive && first) {
        frame.data[kForceAliveByte] = static_cast<std::uint8_t>(frame.data[kForceAliveByte] + 7);
      }
      push_now(frame);
      continue;
    }
    can::Frame frame = reply;
    switch (kind) {
      case InjectionKind::kDropDrive:
        continue;
      case InjectionKind::kLateDrive:
        if (out.late_count < out.late.size()) out.late[out.late_count++] = frame;
        continue;
      case InjectionKind::kCorruptReserved:
        frame.data[kStatusLowByte] = static_cast<std::uint8_t>(frame.data[kStatusLowByte] | kReservedStatusBit);
        break;
      case InjectionKind::kCorruptAlive:
        if (first) frame.data[kAliveByte] = static_cast<std::uint8_t>(frame.data[kAliveByte] + 7);
        break;
      case InjectionKind::kCorruptPosition:
        frame.data[kPositionTopByte] = static_cast<std::uint8_t>(frame.data[kPositionTopByte] ^ 0x20);
        break;
      case InjectionKind::kWrongDlc:
        frame.dlc = 6;
        frame.data[kAliveByte] = 0;  // bytes past the DLC are 0
        break;
      case InjectionKind::kDuplicate:
        push_now(frame);
        break;
      case InjectionKind::kDropForce:
      case InjectionKind::kCorruptForceAlive:
      case InjectionKind::kDriveFault:
      case InjectionKind::kPush:
        break;  // the drive's frame as the nodes made it (a drive fault is in its status word)
    }
    push_now(frame);
  }
}

}  // namespace clm::sim
