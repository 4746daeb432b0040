#include "daemon/servod/telemetry_bridge.hpp"

#include <cmath>
#include <cstdio>

namespace clm::servod {

TelemetryBridge::TelemetryBridge(telemetry::TelemetryPublisher& publisher, const ServoDaemon& daemon)
    : publisher_(&publisher), daemon_(&daemon) {
  const double rate_hz = daemon.config().telemetry.status_rate_hz;
  status_every_cycles_ = std::max<std::int64_t>(1, std::llround(1.0 / (rate_hz * daemon.config().servo.period_s)));
}

TelemetryBridge::TelemetryBridge(telemetry::TelemetrySink& sink, const ServoDaemon& daemon, int state_decimation)
    : sink_(&sink), daemon_(&daemon), state_decimation_(std::max(1, state_decimation)) {
  const double rate_hz = daemon.config().telemetry.status_rate_hz;
  status_every_cycles_ = std::max<std::int64_t>(1, std::llround(1.0 / (rate_hz * daemon.config().servo.period_s)));
}

void TelemetryBridge::fill_status(const servo::ServoCycle& cycle, const LoopTiming& timing,
                                  telemetry::ServoStatusSample& out) const noexcept {
  const auto& c = cycle.counters();
  out.utime = 0;
  out.axis.assign(daemon_->config().axis_name);
  out.session = publisher_ != nullptr ? publisher_->config().session : 0;
  if (authority_ != nullptr) authority_->fill(out.commands);
  out.state = static_cast<std::int8_t>(cycle.state());
  out.fault = static_cast<std::int16_t>(cycle.fault());
  out.fault_reason.assign(servo::describe(cycle.fault()));
  out.fault_cycle = cycle.fault_cycle();
  out.commutation = static_cast<std::int8_t>(cycle.mode());
  out.wakeup_latency_p50_s = timing.wakeup_latency.quantile_s(0.5);
  out.wakeup_latency_p99_s = timing.wakeup_latency.quantile_s(0.99);
  out.wakeup_latency_max_s = timing.wakeup_latency.max_s();
  out.compute_time_p50_s = timing.compute_time.quantile_s(0.5);
  out.compute_time_p99_s = timing.compute_time.quantile_s(0.99);
  out.compute_time_max_s = timing.compute_time.max_s();
  out.overruns = c.overruns;
  out.cycles = c.cycles;
  out.frames_sent = c.frames_sent;
  out.frames_received = c.frames_received;
  out.frames_missing = c.frames_missing;
  out.frames_late = c.frames_late;
  out.frames_rejected = c.frames_rejected;
  out.bus_state = daemon_->config().can.interface == "sim" ? -1 : static_cast<std::int8_t>(daemon_->bus_state());
  out.damping_cycles = c.damping_cycles;
  out.program_running = cycle.record().program_running;
  out.program_time_s = cycle.record().program_time_s;
}

void TelemetryBridge::on_cycle(const servo::ServoCycle& cycle, const LoopTiming& timing) noexcept {
  const std::int64_t n = cycle.record().cycle;
  const bool changed = cycle.state() != last_state_ || cycle.fault() != last_fault_;
  if (changed) {
    event_.utime = 0;
    event_.cycle = n;
    event_.code = static_cast<std::int16_t>(cycle.fault());
    event_.severity = cycle.state() == servo::ServoState::kFault ? 2 : 0;
    char text[128];
    std::snprintf(text, sizeof(text), "state %s, fault %d: %s", servo::name(cycle.state()),
                  static_cast<int>(cycle.fault()), servo::describe(cycle.fault()));
    event_.text.assign(text);
    last_state_ = cycle.state();
    last_fault_ = cycle.fault();
  }
  const bool status_due = n % status_every_cycles_ == 0;
  if (publisher_ != nullptr) {
    publisher_->push_state(cycle.record());  // decimation and drop counting inside
    if (changed) publisher_->push_event(event_);
    if (status_due) {
      fill_status(cycle, timing, status_);
      publisher_->push_status(status_);
    }
    return;
  }
  // Offline: straight to the sink; conversion allocates, which is fine off the real-time path.
  try {
    if (n % state_decimation_ == 0) {
      telemetry::publish_message(*sink_, telemetry::kStateChannel, telemetry::to_message(cycle.record()),
                                 telemetry::wall_clock_utime());
    }
    if (changed) {
      telemetry::publish_message(*sink_, telemetry::kEventChannel, telemetry::to_message(event_),
                                 telemetry::wall_clock_utime());
    }
    if (status_due) {
      fill_status(cycle, timing, status_);
      telemetry::publish_message(*sink_, telemetry::kStatusChannel, telemetry::to_message(status_, 0),
                                 telemetry::wall_clock_utime());
    }
  } catch (...) {
    // A failing log sink must not stop the loop; the writer reports the error on close().
  }
}

}  // namespace clm::servod
