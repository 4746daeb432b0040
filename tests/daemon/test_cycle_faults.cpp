// Faults a healthy motor and a sound law cannot provoke, on the servo cycle
// alone: a law whose setpoints do not fit the CAN signal or are not finite.
// Feedback frames are made with the protocol's encoder, and the frames the
// cycle returns are decoded with its decoder: the fault cycle's own frames
// must already carry zero magnitudes with enable cleared.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "daemon/servo/servo_cycle.hpp"
#include "drivers/can/can_protocol.hpp"
#include "tests/daemon/daemon_support.hpp"

using namespace clm;
using servo::Fault;
using servo::ServoState;

namespace {

/// A law that asks for the same setpoint on every coil set, whatever the demand.
class FixedLaw final : public CommutationLaw {
 public:
  FixedLaw(int coil_sets, DriveSetpoint setpoint) : coil_sets_(coil_sets), setpoint_(setpoint) {}
  int coil_sets() const noexcept override { return coil_sets_; }
  void commutate(double, const Wrench& desired, CommutationOutput& out) const noexcept override {
    out.coil_sets = coil_sets_;
    out.currents_A.setZero();
    for (int l = 0; l < coil_sets_; ++l) out.setpoints[static_cast<std::size_t>(l)] = setpoint_;
    out.model_wrench = desired;
  }

 private:
  int coil_sets_;
  DriveSetpoint setpoint_;
};

/// The cycle with a loop around it that stands in for the bus and the nodes.
class BareCycle {
 public:
  explicit BareCycle(const servo::ServoSettings& settings) : cycle(settings), protocol_(settings.protocol) {}

  /// One cycle with timely feedback at `position_m`; the frames the cycle returned, decoded.
  test::SentSetpoints run(double position_m) {
    time_ns_ += 1'000'000;
    (void)cycle.begin_cycle({.sync_time_ns = time_ns_});
    drivers::ReceivedFrame drive{{}, time_ns_};
    drivers::ReceivedFrame force{{}, time_ns_};
    REQUIRE(can::encode_drive_feedback(protocol_, {position_m, can::kStatusEnabled, alive_}, drive.frame) ==
            can::CodecStatus::kOk);
    REQUIRE(can::encode_force_feedback(protocol_, {Wrench::Zero(), alive_}, force.frame) == can::CodecStatus::kOk);
    ++alive_;
    cycle.on_frame(drive);
    cycle.on_frame(force);
    REQUIRE(cycle.feedback_complete());
    test::SentSetpoints sent;
    unsigned mask = 0;
    for (const can::Frame& frame : cycle.end_cycle(static_cast<double>(time_ns_) * 1e-9, {})) {
      ++sent.frames;
      for (std::size_t index = 0; index < can::setpoint_frame_count(protocol_.coil_sets); ++index) {
        if (frame.id != can::setpoint_id(protocol_, index)) continue;
        REQUIRE(can::decode_setpoint_frame(protocol_, frame, sent.command) == can::CodecStatus::kOk);
        mask |= 1u << index;
      }
    }
    sent.complete = mask == (1u << can::setpoint_frame_count(protocol_.coil_sets)) - 1;
    return sent;
  }

  servo::ServoCycle cycle;

 private:
  can::ProtocolConfig protocol_;
  std::int64_t time_ns_ = 0;
  std::uint8_t alive_ = 0;
};

void require_faulted_and_safe(BareCycle& bare, const test::SentSetpoints& sent, Fault expected) {
  REQUIRE(bare.cycle.status().state == ServoState::kFault);
  CHECK(bare.cycle.status().fault == expected);
  REQUIRE(sent.complete);
  CHECK_FALSE(sent.command.enable);
  CHECK(sent.all_magnitudes_zero());
  for (int k = 0; k < 10; ++k) {
    const auto next = bare.run(0.0);
    REQUIRE(next.complete);
    CHECK_FALSE(next.command.enable);
    CHECK(next.all_magnitudes_zero());
    CHECK(bare.cycle.status().fault == expected);
  }
}

}  // namespace

TEST_CASE("a setpoint outside the CAN signal range latches kSetpointOutOfRange with zero in the same cycle",
          "[daemon][faults]") {
  const auto settings = test::ideal_plant_config().servo;
  BareCycle bare(settings);
  const FixedLaw law(settings.protocol.coil_sets, {1000.0, 0.1});  // the signal ends at ±819.2 N
  bare.cycle.install_law(servo::CommutationMode::kOriginal, &law);
  bare.run(0.0);
  REQUIRE(bare.cycle.execute({.kind = servo::CommandKind::kEnable}) == servo::CommandResult::kAccepted);
  const auto sent = bare.run(0.0);
  require_faulted_and_safe(bare, sent, Fault::kSetpointOutOfRange);
  CHECK(bare.cycle.execute({.kind = servo::CommandKind::kClearFault}) == servo::CommandResult::kAccepted);
  CHECK(bare.cycle.status().state == ServoState::kDisabled);
}

TEST_CASE("a law that produces a non-finite setpoint latches kCommutationNotFinite with zero in the same cycle",
          "[daemon][faults]") {
  const auto settings = test::ideal_plant_config().servo;
  BareCycle bare(settings);
  const FixedLaw law(settings.protocol.coil_sets, {std::numeric_limits<double>::quiet_NaN(), 0.0});
  bare.cycle.install_law(servo::CommutationMode::kOriginal, &law);
  bare.run(0.0);
  REQUIRE(bare.cycle.execute({.kind = servo::CommandKind::kEnable}) == servo::CommandResult::kAccepted);
  const auto sent = bare.run(0.0);
  require_faulted_and_safe(bare, sent, Fault::kCommutationNotFinite);
}

TEST_CASE("a law whose setpoints fit drives the axis through the bare cycle", "[daemon][faults]") {
  const auto settings = test::ideal_plant_config().servo;
  BareCycle bare(settings);
  const FixedLaw law(settings.protocol.coil_sets, {12.5, -0.25});
  bare.cycle.install_law(servo::CommutationMode::kOriginal, &law);
  bare.run(0.0);
  REQUIRE(bare.cycle.execute({.kind = servo::CommandKind::kEnable}) == servo::CommandResult::kAccepted);
  const auto sent = bare.run(0.0);
  REQUIRE(bare.cycle.status().state == ServoState::kEnabled);
  REQUIRE(sent.complete);
  CHECK(sent.command.enable);
  for (int l = 0; l < sent.command.coil_sets; ++l) {
    CHECK(sent.command.setpoints[static_cast<std::size_t>(l)].magnitude_N == 12.5);
    CHECK(sent.command.setpoints[static_cast<std::size_t>(l)].delta_rad == Approx(-0.25).margin(1e-12));
  }
}
