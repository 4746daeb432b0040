#pragma once
// What a drive reports of itself, whatever its protocol: each protocol's
// status (the project's status word, drivers/can/can_protocol.hpp; a CiA 402
// statusword) is decoded into these signals once, and the servo cycle reacts
// to them alone (docs/servod.md, "The drive's own signals").

namespace clm::drivers {

struct DriveSignals {
  /// The drive applies current: its power stage is on and its current loop
  /// runs. The enable handshake completes when it says so.
  bool enabled = false;
  /// The drive latched a fault of its own and stopped the current.
  bool fault = false;
  /// Its setpoint watchdog expired: setpoints stopped coming while it was enabled.
  bool watchdog_expired = false;
  /// It limited a phase current during its last period: the force asked
  /// for was not all delivered.
  bool current_limited = false;
  /// A limit switch or an end stop is active.
  bool end_stop = false;
  /// Its position latch caught its event since it was armed; clears when disarmed.
  bool latched = false;
  /// The reference switch is active now.
  bool reference_switch = false;
};

}  // namespace clm::drivers
