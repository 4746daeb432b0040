#include "drivers/sim/in_process_bus.hpp"

#include <algorithm>
#include <ctime>
#include <stdexcept>

#include "drivers/sim/injection_plan.hpp"

namespace clm::sim {
namespace {

struct PlannedName {
  const char* name;
  PlannedFault fault;
  bool counted;    ///< takes ":N"
  bool valued;     ///< needs ":N:value"
};
constexpr std::array<PlannedName, 15> kPlannedNames{{
    {"drop-drive", PlannedFault::kDropDrive, true, false},
    {"drop-force", PlannedFault::kDropForce, true, false},
    {"late-drive", PlannedFault::kLateDrive, true, false},
    {"duplicate", PlannedFault::kDuplicate, true, false},
    {"wrong-dlc", PlannedFault::kWrongDlc, true, false},
    {"corrupt-alive", PlannedFault::kCorruptAlive, false, false},
    {"corrupt-force-alive", PlannedFault::kCorruptForceAlive, false, false},
    {"corrupt-position", PlannedFault::kCorruptPosition, true, false},
    {"drop-setpoints", PlannedFault::kDropSetpoints, true, false},
    {"drive-fault", PlannedFault::kDriveFault, false, false},
    {"bus-off", PlannedFault::kBusOff, true, false},
    {"error-passive", PlannedFault::kErrorPassive, true, false},
    {"fail-sends", PlannedFault::kFailSends, true, false},
    {"push", PlannedFault::kPush, true, true},
    {"stall", PlannedFault::kStall, true, true},
}};

// The alive counters jump as a node that restarted or lost frames would show.
constexpr int kAliveJump = 7;

}  // namespace

std::vector<PlannedStep> parse_planned_faults(const std::string& plan) {
  std::vector<PlannedStep> steps;
  for (const PlanItem& item : parse_plan_items(plan)) {
    const auto* known = std::find_if(kPlannedNames.begin(), kPlannedNames.end(),
                                     [&](const PlannedName& n) { return item.name == n.name; });
    if (known == kPlannedNames.end()) throw std::invalid_argument("injection plan: unknown step '" + item.text + "'");
    const bool counted = item.text.find(':') != std::string::npos;
    if (counted && !known->counted) {
      throw std::invalid_argument("injection plan: step '" + item.text + "' takes no count");
    }
    if (known->valued != item.has_value) {
      throw std::invalid_argument("injection plan: step '" + item.text + "': " +
                                  (known->valued ? "needs name:count:value" : "takes no value"));
    }
    if (known->fault == PlannedFault::kPush && !(item.value > 0.0)) {
      throw std::invalid_argument("injection plan: step '" + item.text + "': the force must be > 0 N");
    }
    if (known->fault == PlannedFault::kStall && !(item.value > 0.0 && item.value <= 0.1)) {
      throw std::invalid_argument("injection plan: step '" + item.text + "': the stall must be 0 < S <= 0.1 s");
    }
    steps.push_back({known->fault, item.count, item.value});
  }
  return steps;
}

InProcessBus::InProcessBus(SimulatedNodes& nodes) : nodes_(&nodes) {}

void InProcessBus::enqueue(const can::Frame& frame, std::int64_t stamp_ns) noexcept {
  if (tail_ - head_ >= kCapacity) return;  // full: the frame is lost, as on a real bus
  ring_[tail_ % kCapacity] = {frame, stamp_ns};
  ++tail_;
}

void InProcessBus::run_plan() noexcept {
  // A push lets go once the drive is disabled: it tests the reaction, it
  // does not throw the translator into an end stop.
  const bool let_go = timed_ != nullptr && timed_->fault == PlannedFault::kPush && !nodes_->motor().status().enabled();
  if (timed_ != nullptr && (--timed_left_ < 0 || let_go)) {
    switch (timed_->fault) {
      case PlannedFault::kBusOff:
      case PlannedFault::kErrorPassive: injection_.bus_state = drivers::BusState::kActive; break;
      case PlannedFault::kFailSends: injection_.fail_sends = false; break;
      case PlannedFault::kPush: nodes_->motor().set_disturbance_force_N(0.0); break;
      default: break;
    }
    timed_ = nullptr;
  }
  const int fired = fired_.load(std::memory_order_relaxed);
  if (fired >= static_cast<int>(plan_.size()) || requested_.load(std::memory_order_relaxed) <= fired) return;
  const PlannedStep& step = plan_[static_cast<std::size_t>(fired)];
  fired_.store(fired + 1, std::memory_order_relaxed);
  Injection& in = injection_;
  switch (step.fault) {
    case PlannedFault::kDropDrive: in.drop_drive_frames = step.cycles; break;
    case PlannedFault::kDropForce: in.drop_force_frames = step.cycles; break;
    case PlannedFault::kLateDrive: in.delay_drive_frames = step.cycles; break;
    case PlannedFault::kDuplicate: in.duplicate_drive_frames = step.cycles; break;
    case PlannedFault::kWrongDlc: in.wrong_dlc_drive_frames = step.cycles; break;
    case PlannedFault::kCorruptAlive: in.skip_drive_alive = kAliveJump; break;
    case PlannedFault::kCorruptForceAlive: in.skip_force_alive = kAliveJump; break;
    case PlannedFault::kCorruptPosition: in.corrupt_position_frames = step.cycles; break;
    case PlannedFault::kDropSetpoints: in.drop_setpoint_frames = step.cycles; break;
    case PlannedFault::kDriveFault: nodes_->motor().latch_internal_fault(); break;
    case PlannedFault::kBusOff: in.bus_state = drivers::BusState::kBusOff; break;
    case PlannedFault::kErrorPassive: in.bus_state = drivers::BusState::kErrorPassive; break;
    case PlannedFault::kFailSends: in.fail_sends = true; break;
    case PlannedFault::kPush: {
      const double velocity = nodes_->motor().truth().velocity_m_per_s;
      nodes_->motor().set_disturbance_force_N(velocity > 0.0 ? -step.value : step.value);
      break;
    }
    case PlannedFault::kStall: break;
  }
  switch (step.fault) {
    case PlannedFault::kBusOff:
    case PlannedFault::kErrorPassive:
    case PlannedFault::kFailSends:
    case PlannedFault::kPush:
    case PlannedFault::kStall:
      timed_ = &step;
      timed_left_ = step.cycles - 1;
      break;
    default: break;
  }
}

bool InProcessBus::send(const can::Frame& frame) noexcept {
  if (frame.id == can::kSyncId) {
    monitor_count_ = 0;  // a new cycle, even if its SYNC is refused
    run_plan();
    if (timed_ != nullptr && timed_->fault == PlannedFault::kStall) {
      // The loop is held here as by a stalled host: a real overrun.
      const auto ns = static_cast<long>(timed_->value * 1e9);
      const timespec pause{ns / 1'000'000'000L, ns % 1'000'000'000L};
      nanosleep(&pause, nullptr);
    }
  }
  if (injection_.fail_sends) return false;
  if (frame.id != can::kSyncId && monitor_count_ < monitor_.size()) monitor_[monitor_count_++] = frame;
  if (frame.id != can::kSyncId && injection_.drop_setpoint_frames > 0) {
    --injection_.drop_setpoint_frames;
    return true;  // sent, but lost on the way
  }
  if (frame.id == can::kSyncId) {
    // Frames held back last cycle arrive now, stamped before this SYNC.
    for (std::size_t k = 0; k < delayed_count_; ++k) enqueue(delayed_[k].frame, delayed_[k].timestamp_ns);
    delayed_count_ = 0;
  }
  std::array<can::Frame, SimulatedNodes::kMaxReplies> replies{};  // latch, drive and force feedback
  const std::size_t count = nodes_->on_frame(frame, replies);
  const can::ProtocolConfig& protocol = nodes_->protocol();
  if (frame.id == can::kSyncId && injection_.spoof_latch) {
    injection_.spoof_latch = false;
    can::Frame spoofed;
    if (can::encode_drive_latch(protocol, {injection_.spoof_latch_position_m, 0}, spoofed) == can::CodecStatus::kOk) {
      enqueue(spoofed, time_ns_);
    }
  }
  for (std::size_t k = 0; k < count; ++k) {
    can::Frame reply = replies[k];
    if (reply.id == can::drive_feedback_id(protocol)) {
      Injection& in = injection_;
      if (in.drop_drive_frames > 0) {
        --in.drop_drive_frames;
        continue;
      }
      if (in.skip_drive_alive != 0) {
        reply.data[6] = static_cast<std::uint8_t>(reply.data[6] + in.skip_drive_alive);
        in.skip_drive_alive = 0;
      }
      if (in.wrong_dlc_drive_frames > 0) {
        --in.wrong_dlc_drive_frames;
        reply.dlc = 5;
      }
      if (in.corrupt_position_frames > 0) {
        --in.corrupt_position_frames;
        reply.data[0] = 0xff;
        reply.data[1] = 0xff;
        reply.data[2] = 0xff;
        reply.data[3] = 0x7f;
      }
      if (in.delay_drive_frames > 0 && delayed_count_ < delayed_.size()) {
        --in.delay_drive_frames;
        delayed_[delayed_count_++] = {reply, time_ns_};
        continue;
      }
      enqueue(reply, time_ns_);
      if (in.duplicate_drive_frames > 0) {
        --in.duplicate_drive_frames;
        enqueue(reply, time_ns_);
      }
      continue;
    }
    // The drive's latch frame (TPDO2, first of the replies in its period)
    // is enqueued below, in this period and in the nodes' order, ahead of
    // the drive feedback it precedes on the bus (a delayed feedback frame
    // only comes later still), unless the injection drops it.
    if (reply.id == can::drive_latch_id(protocol) && injection_.drop_latch_frames > 0) {
      --injection_.drop_latch_frames;
      continue;
    }
    if (reply.id == can::force_feedback_id(protocol)) {
      if (injection_.drop_force_frames > 0) {
        --injection_.drop_force_frames;
        continue;
      }
      if (injection_.skip_force_alive != 0) {
        reply.data[7] = static_cast<std::uint8_t>(reply.data[7] + injection_.skip_force_alive);
        injection_.skip_force_alive = 0;
      }
    }
    enqueue(reply, time_ns_);
  }
  return true;
}

bool InProcessBus::receive(drivers::ReceivedFrame& out, std::int64_t /*deadline_ns*/) noexcept {
  if (head_ == tail_) return false;
  out = ring_[head_ % kCapacity];
  ++head_;
  return true;
}

}  // namespace clm::sim
