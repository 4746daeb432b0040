// The one mapping of a command to the wire (telemetry::to_message) and back
// (telemetry::to_command): every kind's fields survive the round trip, the
// fields it does not use go out zero or empty, and the result passes the
// daemon's own check of a received command.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "daemon/servo/command.hpp"
#include "daemon/telemetry/lcm_conversion.hpp"

using namespace clm;
using servo::CommandKind;

namespace {

servo::Command filled(CommandKind kind) {
  servo::Command command{.kind = kind};
  command.utime = 1'700'000'000'000'000;
  command.sequence = 42;
  REQUIRE(command.axis.assign("axis0"));
  command.session = 0x5eed;
  command.client = 7;
  switch (kind) {
    case CommandKind::kMoveTo:
      command.target_m = 0.0375;
      command.limits = {0.25, 2.5, 750.0};
      break;
    case CommandKind::kJog:
      command.jog_velocity_m_per_s = -0.125;
      command.limits = {0.125, 1.5, 500.0};
      break;
    case CommandKind::kRunProgram: REQUIRE(command.program.assign("/etc/clm-servo/programs/fig8.yaml")); break;
    case CommandKind::kSetCommutation: command.commutation = servo::CommutationMode::kSpline; break;
    case CommandKind::kSetExperiment:
      command.commutation = servo::CommutationMode::kExperiment;
      command.coil_set = 2;
      command.delta_rad = -0.785;
      break;
    case CommandKind::kLoadCalibration:
    case CommandKind::kLoadModel:
    case CommandKind::kLoadFeedforward: REQUIRE(command.path.assign("/var/lib/clm-servo/file.yaml")); break;
    case CommandKind::kSetParameter: command.value = 40.0; [[fallthrough]];
    case CommandKind::kGetParameter: REQUIRE(command.parameter.assign("control.bandwidth_hz")); break;
    default: break;
  }
  return command;
}

}  // namespace

TEST_CASE("every command kind survives to_message and to_command with the fields of its kind", "[telemetry][command]") {
  for (int code = 1; code <= servo::kCommandKinds; ++code) {
    const auto kind = static_cast<CommandKind>(code);
    const servo::Command sent = filled(kind);
    const clm_lcm::servo_command_t message = telemetry::to_message(sent);
    INFO("kind " << servo::route(kind).name);
    CHECK(message.command == code);
    servo::Command received;
    REQUIRE(telemetry::to_command(message, received) == "");
    CHECK(received.kind == kind);
    CHECK(received.utime == sent.utime);
    CHECK(received.sequence == sent.sequence);
    CHECK(received.axis.view() == sent.axis.view());
    CHECK(received.session == sent.session);
    CHECK(received.client == sent.client);
    CHECK(received.program.view() == sent.program.view());
    CHECK(received.path.view() == sent.path.view());
    CHECK(received.parameter.view() == sent.parameter.view());
    CHECK(received.value == sent.value);
    switch (kind) {
      case CommandKind::kMoveTo:
        CHECK(received.target_m == sent.target_m);
        CHECK(received.limits.velocity_m_per_s == sent.limits.velocity_m_per_s);
        CHECK(received.limits.acceleration_m_per_s2 == sent.limits.acceleration_m_per_s2);
        CHECK(received.limits.jerk_m_per_s3 == sent.limits.jerk_m_per_s3);
        break;
      case CommandKind::kJog:
        CHECK(received.jog_velocity_m_per_s == sent.jog_velocity_m_per_s);
        CHECK(received.limits.velocity_m_per_s == std::abs(sent.jog_velocity_m_per_s));
        CHECK(received.limits.acceleration_m_per_s2 == sent.limits.acceleration_m_per_s2);
        CHECK(received.limits.jerk_m_per_s3 == sent.limits.jerk_m_per_s3);
        break;
      case CommandKind::kSetCommutation:
      case CommandKind::kSetExperiment:
        CHECK(received.commutation == sent.commutation);
        CHECK(received.coil_set == sent.coil_set);
        CHECK(received.delta_rad == sent.delta_rad);
        break;
      default:
        // Fields of other kinds go out zero.
        CHECK(message.target_m == 0.0);
        CHECK(message.velocity_m_per_s == 0.0);
        CHECK(message.acceleration_m_per_s2 == 0.0);
        CHECK(message.jerk_m_per_s3 == 0.0);
        CHECK(message.commutation == 0);
        CHECK(message.coil_set == 0);
        CHECK(message.delta_rad == 0.0);
        break;
    }
  }
}
