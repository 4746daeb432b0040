#pragma once
// Telemetry of the servo cycle: every cycle's record (decimated), a status at
// the configured rate, and an event when a fault latches or the state
// changes. In the daemon the samples go through the publisher's lock-free
// queues (nothing blocks or allocates on the loop thread); offline (commissioning
// on the virtual clock) they are written straight to a sink such as an LCM log,
// so nothing is dropped.

#include <array>
#include <string>

#include "daemon/servod/servo_daemon.hpp"
#include "daemon/telemetry/telemetry.hpp"

namespace clm::servod {

/// servo_event_t.code of the events the bridge emits beside fault and state
/// changes, whose code is the fault's (docs/telemetry.md, "Events").
enum class EventCode : std::int16_t {
  kCommutationChanged = 300,  ///< the cycle commutates with another law (mode)
  kLawSwapped = 301,          ///< a newly loaded law took over its mode at standstill
  kFileLoaded = 302,          ///< the status names a new file (calibration, model, feedforward)
  kProgramStarted = 303,
  kProgramEnded = 304,
  kRequestSuperseded = 305,   ///< a deferred law request was replaced before it took effect
  kForceSensorLost = 306,     ///< the force sensor was lost in service (a warning, not a fault)
  kForceSensorBack = 307,     ///< its frames come again
  // 308 is a recorder's, not the daemon's: telemetry::kRecordingResumedEvent.
  kOtherSession = 309,        ///< another session's status of this axis: the axis was disabled (command server)
  kDeadmanLapsed = 310,       ///< a deadman lease lapsed: axis stopped, experiment ended, control released (command server)
};

/// Who reports the command authority's part of the status (the command
/// server). fill() runs on the loop thread: it must not block or allocate.
class AuthorityReport {
 public:
  virtual void fill(telemetry::CommandAuthorityStatus& out) const noexcept = 0;

 protected:
  ~AuthorityReport() = default;
};

class TelemetryBridge final : public CycleObserver {
 public:
  /// Real-time use: samples go to `publisher`'s queues.
  TelemetryBridge(telemetry::TelemetryPublisher& publisher, const ServoDaemon& daemon);
  /// Offline use: samples are encoded and written to `sink` on the calling thread.
  TelemetryBridge(telemetry::TelemetrySink& sink, const ServoDaemon& daemon, int state_decimation);

  void on_cycle(const servo::ServoCycle& cycle, const LoopTiming& timing) noexcept override;

  /// From now on the status carries `report`'s command authority (nullptr:
  /// none, the counters stay 0). Before the loop starts.
  void set_authority(const AuthorityReport* report) noexcept { authority_ = report; }

  void fill_status(const servo::ServoCycle& cycle, const LoopTiming& timing, telemetry::ServoStatusSample& out) const noexcept;

 private:
  /// The configuration file and the motor file, canonical path and SHA-256,
  /// read once at construction; a path too long for the status is left
  /// out (empty), never cut.
  void describe_start_files();
  telemetry::LoadedFileText configuration_{}, motor_{};
  telemetry::TelemetryPublisher* publisher_ = nullptr;
  telemetry::TelemetrySink* sink_ = nullptr;
  const ServoDaemon* daemon_;
  const AuthorityReport* authority_ = nullptr;
  int state_decimation_ = 1;
  std::int64_t status_every_cycles_ = 100;
  servo::ServoState last_state_ = servo::ServoState::kDisabled;
  servo::Fault last_fault_ = servo::Fault::kNone;
  bool primed_ = false;  // the fields below hold the first cycle's values
  servo::CommutationMode last_mode_ = servo::CommutationMode::kOriginal;
  std::array<const CommutationLaw*, servo::kCommutationModes> last_laws_{};
  std::array<std::uint64_t, kLoadedFileSlots> last_files_{};
  bool last_program_running_ = false;
  std::int64_t last_superseded_ = 0;
  servo::Fault last_force_warning_ = servo::Fault::kNone;
  void emit(std::int64_t cycle, EventCode code, std::int8_t severity, const char* text) noexcept;
  void publish_event() noexcept;
  void events(const servo::ServoCycle& cycle, std::int64_t n) noexcept;
  telemetry::ServoStatusSample status_{};
  telemetry::ServoEventSample event_{};
};

}  // namespace clm::servod
