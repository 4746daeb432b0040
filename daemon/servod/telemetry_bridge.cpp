#include "daemon/servod/telemetry_bridge.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>

namespace clm::servod {

TelemetryBridge::TelemetryBridge(telemetry::TelemetryPublisher& publisher, const ServoDaemon& daemon)
    : publisher_(&publisher), daemon_(&daemon) {
  const double rate_hz = daemon.config().telemetry.status_rate_hz;
  status_every_cycles_ = std::max<std::int64_t>(1, std::llround(1.0 / (rate_hz * daemon.config().servo.period_s)));
  describe_start_files();
}

TelemetryBridge::TelemetryBridge(telemetry::TelemetrySink& sink, const ServoDaemon& daemon, int state_decimation)
    : sink_(&sink), daemon_(&daemon), state_decimation_(std::max(1, state_decimation)) {
  const double rate_hz = daemon.config().telemetry.status_rate_hz;
  status_every_cycles_ = std::max<std::int64_t>(1, std::llround(1.0 / (rate_hz * daemon.config().servo.period_s)));
  describe_start_files();
}

void TelemetryBridge::describe_start_files() {
  const ServodConfig& config = daemon_->config();
  const auto describe = [](const std::string& path, const std::string& sha256, telemetry::LoadedFileText& out) {
    std::error_code error;
    const std::filesystem::path canonical = std::filesystem::weakly_canonical(path, error);
    if (error || sha256.empty() || !out.path.assign(canonical.string())) {
      out = {};
      return;
    }
    out.sha256.assign(sha256);
  };
  describe(config.origin, config.origin_sha256, configuration_);
  describe(config.motor_file, config.motor_sha256, motor_);
}

void TelemetryBridge::fill_status(const servo::ServoCycle& cycle, const LoopTiming& timing,
                                  telemetry::ServoStatusSample& out) const noexcept {
  const auto& c = cycle.status().counters;
  out.utime = 0;
  out.axis.assign(daemon_->config().axis_name);
  out.session = publisher_ != nullptr ? publisher_->config().session : 0;
  if (authority_ != nullptr) authority_->fill(out.commands);
  out.state = static_cast<std::int8_t>(cycle.status().state);
  out.fault = static_cast<std::int16_t>(cycle.status().fault);
  out.fault_reason.assign(servo::describe(cycle.status().fault));
  out.fault_cycle = cycle.status().fault_cycle;
  out.commutation = static_cast<std::int8_t>(cycle.status().mode);
  out.wakeup_latency_p50_s = timing.wakeup_latency.quantile_s(0.5);
  out.wakeup_latency_p99_s = timing.wakeup_latency.quantile_s(0.99);
  out.wakeup_latency_max_s = timing.wakeup_latency.max_s();
  out.compute_time_p50_s = timing.compute_time.quantile_s(0.5);
  out.compute_time_p99_s = timing.compute_time.quantile_s(0.99);
  out.compute_time_max_s = timing.compute_time.max_s();
  static_assert(servo::LatencyHistogram::kCoarseBins == telemetry::kTimingHistogramBins);
  out.wakeup_latency_histogram = timing.wakeup_latency.coarse_counts();
  out.compute_time_histogram = timing.compute_time.coarse_counts();
  out.overruns = c.overruns;
  out.cycles = c.cycles;
  out.frames_sent = c.frames_sent;
  out.frames_received = c.frames_received;
  out.frames_missing = c.frames_missing;
  out.frames_late = c.frames_late;
  out.frames_rejected = c.frames_rejected;
  out.bus_state = static_cast<std::int8_t>(daemon_->bus_state());  // the embedded bus reports its injected states too
  out.damping_cycles = c.damping_cycles;
  out.program_running = cycle.record().program_running;
  out.program_time_s = cycle.record().program_time_s;
  out.restricted = cycle.record().restricted;
  const servo::Fault force_warning = cycle.status().force_sensor_warning;
  out.force_sensor = !can::has_force_sensor(cycle.settings().protocol) ? telemetry::kForceSensorNone
                     : force_warning == servo::Fault::kNone          ? telemetry::kForceSensorOk
                                                                     : telemetry::kForceSensorLost;
  out.force_sensor_warning = static_cast<std::int16_t>(force_warning);
  out.force_sensor_losses = c.force_sensor_losses;
  out.drive_signals = telemetry::drive_signal_bits(cycle.status().drive);
  out.enabling = cycle.status().enabling;
  out.current_limited_cycles = c.current_limited_cycles;
  const auto& status = cycle.status();
  out.commutation_found = status.commutation_found;
  out.homed = status.homed;
  out.homing = static_cast<std::int8_t>(status.homing);
  out.found_phase_rad = status.found_phase_rad;
  out.axis_offset_m = status.axis_offset_m;
  daemon_->loaded_file(LoadedFileSlot::kCalibration, out.calibration);
  daemon_->loaded_file(LoadedFileSlot::kPgnnModel, out.pgnn_model);
  daemon_->loaded_file(LoadedFileSlot::kSplineModel, out.spline_model);
  daemon_->loaded_file(LoadedFileSlot::kFeedforward, out.feedforward);
  out.configuration = configuration_;
  out.motor = motor_;
  out.commands.refused_by_daemon = daemon_->commands_refused();
}

void TelemetryBridge::publish_event() noexcept {
  if (publisher_ != nullptr) {
    publisher_->push_event(event_);
    return;
  }
  try {
    telemetry::publish_message(*sink_, telemetry::kEventChannel, telemetry::to_message(event_),
                               telemetry::wall_clock_utime());
  } catch (...) {
    // A failing log sink must not stop the loop; the writer reports the error on close().
  }
}

void TelemetryBridge::emit(std::int64_t cycle, EventCode code, std::int8_t severity, const char* text) noexcept {
  event_.utime = 0;
  event_.cycle = cycle;
  event_.code = static_cast<std::int16_t>(code);
  event_.severity = severity;
  event_.text.assign(text);
  publish_event();
}

void TelemetryBridge::events(const servo::ServoCycle& cycle, std::int64_t n) noexcept {
  char text[128];
  telemetry::LoadedFileText file;
  const LoadedFileSlot slots[] = {LoadedFileSlot::kCalibration, LoadedFileSlot::kPgnnModel,
                                  LoadedFileSlot::kSplineModel, LoadedFileSlot::kFeedforward};
  static constexpr const char* kSlotNames[] = {"calibration", "pgnn model", "spline model", "feedforward"};
  if (!primed_) {
    // The first cycle: what the daemon started with is no change.
    primed_ = true;
    last_mode_ = cycle.status().mode;
    for (int m = 0; m < servo::kCommutationModes; ++m) last_laws_[m] = cycle.law(static_cast<servo::CommutationMode>(m));
    for (std::size_t i = 0; i < kLoadedFileSlots; ++i) last_files_[i] = daemon_->loaded_file(slots[i], file);
    last_program_running_ = cycle.record().program_running;
    last_superseded_ = daemon_->superseded().count;
    last_force_warning_ = cycle.status().force_sensor_warning;
    return;
  }
  if (cycle.status().force_sensor_warning != last_force_warning_) {
    last_force_warning_ = cycle.status().force_sensor_warning;
    if (last_force_warning_ == servo::Fault::kNone) {
      emit(n, EventCode::kForceSensorBack, 0, "force sensor back: its frames come again");
    } else {
      std::snprintf(text, sizeof text, "force sensor lost in service (%d: %s): a warning, a fault only in an experiment",
                    static_cast<int>(last_force_warning_), servo::describe(last_force_warning_));
      emit(n, EventCode::kForceSensorLost, 1, text);
    }
  }
  if (cycle.status().mode != last_mode_) {
    std::snprintf(text, sizeof text, "commutation %s (was %s)", servo::name(cycle.status().mode), servo::name(last_mode_));
    last_mode_ = cycle.status().mode;
    emit(n, EventCode::kCommutationChanged, 0, text);
  }
  for (int m = 0; m < servo::kCommutationModes; ++m) {
    const auto mode = static_cast<servo::CommutationMode>(m);
    const CommutationLaw* law = cycle.law(mode);
    if (law == last_laws_[m]) continue;
    last_laws_[m] = law;
    std::snprintf(text, sizeof text, "%s law swapped in%s", servo::name(mode), mode == cycle.status().mode ? ", in use" : "");
    emit(n, EventCode::kLawSwapped, 0, text);
  }
  for (std::size_t i = 0; i < kLoadedFileSlots; ++i) {
    // Every cycle looks; the text is copied only when a new file came.
    if (daemon_->loaded_file_generation(slots[i]) == last_files_[i]) continue;
    const std::uint64_t generation = daemon_->loaded_file(slots[i], file);
    if (generation == last_files_[i] || generation % 2 != 0) continue;
    last_files_[i] = generation;
    // The path's tail fits the event's text; the status has it whole.
    const std::string_view path = file.path.view();
    const std::string_view tail = path.size() > 60 ? path.substr(path.size() - 60) : path;
    std::snprintf(text, sizeof text, "%s file %s%.*s sha256 %.16s", kSlotNames[i], path.size() > 60 ? "..." : "",
                  static_cast<int>(tail.size()), tail.data(), file.sha256.chars.data());
    emit(n, EventCode::kFileLoaded, 0, text);
  }
  const bool running = cycle.record().program_running;
  if (running != last_program_running_) {
    last_program_running_ = running;
    emit(n, running ? EventCode::kProgramStarted : EventCode::kProgramEnded, 0,
         running ? "program started" : "program ended");
  }
  const Superseded& superseded = daemon_->superseded();
  if (superseded.count != last_superseded_) {
    last_superseded_ = superseded.count;
    std::snprintf(text, sizeof text, "law request %lld superseded by request %lld before it took effect",
                  static_cast<long long>(superseded.superseded), static_cast<long long>(superseded.by));
    emit(n, EventCode::kRequestSuperseded, 1, text);
  }
}

void TelemetryBridge::on_cycle(const servo::ServoCycle& cycle, const LoopTiming& timing) noexcept {
  const std::int64_t n = cycle.record().cycle;
  const bool changed = cycle.status().state != last_state_ || cycle.status().fault != last_fault_;
  if (changed) {
    event_.utime = 0;
    event_.cycle = n;
    event_.code = static_cast<std::int16_t>(cycle.status().fault);
    event_.severity = cycle.status().state == servo::ServoState::kFault ? 2 : 0;
    char text[128];
    std::snprintf(text, sizeof(text), "state %s, fault %d: %s", servo::name(cycle.status().state),
                  static_cast<int>(cycle.status().fault), servo::describe(cycle.status().fault));
    event_.text.assign(text);
    last_state_ = cycle.status().state;
    last_fault_ = cycle.status().fault;
  }
  const bool status_due = n % status_every_cycles_ == 0;
  if (publisher_ != nullptr) {
    publisher_->push_state(cycle.record());  // decimation and drop counting inside
    if (changed) publish_event();
    events(cycle, n);
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
    if (changed) publish_event();
    events(cycle, n);
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
