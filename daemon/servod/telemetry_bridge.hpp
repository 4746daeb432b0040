#pragma once
// Telemetry of the servo cycle: every cycle's record (decimated), a status at
// the configured rate, and an event when a fault latches or the state
// changes. In the daemon the samples go through the publisher's lock-free
// queues (nothing blocks or allocates on the loop thread); offline (commissioning
// on the virtual clock) they are written straight to a sink such as an LCM log,
// so nothing is dropped.

#include <string>

#include "daemon/servod/servo_daemon.hpp"
#include "daemon/telemetry/telemetry.hpp"

namespace clm::servod {

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
  telemetry::TelemetryPublisher* publisher_ = nullptr;
  telemetry::TelemetrySink* sink_ = nullptr;
  const ServoDaemon* daemon_;
  const AuthorityReport* authority_ = nullptr;
  int state_decimation_ = 1;
  std::int64_t status_every_cycles_ = 100;
  servo::ServoState last_state_ = servo::ServoState::kDisabled;
  servo::Fault last_fault_ = servo::Fault::kNone;
  telemetry::ServoStatusSample status_{};
  telemetry::ServoEventSample event_{};
};

}  // namespace clm::servod
