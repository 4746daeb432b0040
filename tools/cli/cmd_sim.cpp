// clm sim --can IFACE: the simulated motor as the drive and force-sensor
// nodes on a SocketCAN bus, for hardware-in-the-loop runs of clm-servod over
// vcan (docs/hil.md). The nodes' logic is clm::sim::SimulatedNodes, the
// same the daemon's in-process bus uses: on each SYNC the motor steps one
// period, the encoder and force sensor are sampled and both TPDO1s go out;
// the setpoint RPDOs of a cycle are applied once all of them are in.
//
// The drive keeps its own clock: when the SYNCs stop for 3 periods while it
// is enabled, it steps the motor on CLOCK_MONOTONIC, so its setpoint watchdog
// stops the current after a daemon died (docs/reliability.md). With
// --inject PLAN, each SIGUSR1 fires the next step of a bus-side fault
// injection (clm::sim::BusInjector) at the next SYNC with the axis
// enabled; --event-log FILE records each step fired and each watchdog expiry
// with the SYNC count and the drive's own times.
//
// Runs until SIGINT/SIGTERM or --duration-s, then prints one summary line on
// stdout. Exit status: 0 after a clean stop, 2 on bad input or when the bus
// cannot be opened (e.g. a kernel without SocketCAN), with one line on stderr.
#include <signal.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/command_line.hpp"
#include "drivers/sim/bus_injector.hpp"
#include "drivers/sim/motor.hpp"
#include "drivers/sim/motor_file.hpp"
#include "drivers/sim/simulated_nodes.hpp"
#include "drivers/socket_can_bus.hpp"
#include "tools/cli/commands.hpp"

namespace clm::cli {
namespace {

/// ", fault latched (watchdog expired, end stop)": which latched bits the
/// drive's status word holds; "" without a fault.
std::string latched_fault_text(const sim::DriveStatus& status) {
  if (!status.fault()) return "";
  std::string causes;
  const auto add = [&causes](bool set, const char* cause) {
    if (!set) return;
    causes += causes.empty() ? "" : ", ";
    causes += cause;
  };
  add(status.watchdog(), "watchdog expired");
  add(status.end_stop(), "end stop");
  add(status.invalid_setpoint(), "invalid setpoint");
  return ", fault latched (" + (causes.empty() ? std::string("inside the drive") : causes) + ")";
}

std::atomic<int> g_stop_signal{0};
std::atomic<int> g_injection_requests{0};

extern "C" void on_stop_signal(int signal) { g_stop_signal.store(signal, std::memory_order_relaxed); }
extern "C" void on_injection_request(int) { g_injection_requests.fetch_add(1, std::memory_order_relaxed); }

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

struct SimOptions {
  std::string interface_name;
  std::string motor_file;
  double rate_hz = 1000.0;
  double duration_s = 0.0;  ///< 0: until a signal
  int drive_node_id = 1;
  int force_sensor_node_id = 2;
  std::string injection_plan;  ///< empty: no injection
  std::string event_log;       ///< empty: none
};

/// SYNCs missing, while the drive is enabled, before it steps on its own clock.
constexpr int kFreeRunAfterPeriods = 3;

/// Longest a receive waits, so a signal or the end of the duration is seen
/// within this time even on a silent bus [ns].
constexpr std::int64_t kMaxWait_ns = 50'000'000;

void run_sim(const SimOptions& options) {
  const sim::MotorParameters parameters = sim::load_motor_parameters(options.motor_file);
  sim::SimulatedMotor motor(parameters);

  can::ProtocolConfig protocol;
  protocol.drive_node_id = static_cast<std::uint8_t>(options.drive_node_id);
  protocol.force_sensor_node_id = static_cast<std::uint8_t>(options.force_sensor_node_id);
  protocol.coil_sets = motor.coil_sets();
  protocol.drive_profile = parameters.drive.profile;  // the motor file's drive.profile
  protocol.validate();
  const double period_s = 1.0 / options.rate_hz;
  sim::SimulatedNodes nodes(motor, protocol, period_s);

  // The nodes hear SYNC and the drive's RPDOs for this L, nothing else.
  std::vector<std::uint32_t> receive_ids{can::kSyncId};
  for (std::size_t k = 0; k < can::setpoint_frame_count(protocol.coil_sets); ++k) {
    receive_ids.push_back(can::setpoint_id(protocol, k));
  }
  sim::BusInjector injector(protocol, options.injection_plan.empty()
                                          ? std::vector<sim::InjectionStep>{}
                                          : sim::parse_injection_plan(options.injection_plan));
  std::FILE* events = nullptr;
  if (!options.event_log.empty()) {
    events = std::fopen(options.event_log.c_str(), "w");
    if (events == nullptr) throw std::runtime_error("cannot write the event log '" + options.event_log + "'");
  }
  drivers::SocketCanBus bus(options.interface_name, receive_ids);

  // An asynchronous handler that only sets a flag; without SA_RESTART, so a
  // wait in ppoll returns and the loop sees the flag at once.
  struct sigaction action{};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  struct sigaction inject_action{};
  inject_action.sa_handler = on_injection_request;
  sigemptyset(&inject_action.sa_mask);
  sigaction(SIGUSR1, &inject_action, nullptr);

  std::fprintf(stderr, "clm sim: %s: %d coil sets, drive node %d, force sensor node %d, %g Hz; waiting for SYNC\n",
               options.interface_name.c_str(), protocol.coil_sets, options.drive_node_id, options.force_sensor_node_id,
               options.rate_hz);

  const std::int64_t start_ns = monotonic_ns();
  const std::int64_t end_ns =
      options.duration_s > 0.0 ? start_ns + static_cast<std::int64_t>(options.duration_s * 1e9) : INT64_MAX;
  std::int64_t replies_sent = 0, replies_failed = 0;
  std::array<can::Frame, sim::SimulatedNodes::kMaxReplies> replies{};
  sim::BusInjector::Replies injected;
  drivers::ReceivedFrame received;
  const auto period_ns = static_cast<std::int64_t>(period_s * 1e9);
  std::int64_t last_step_ns = 0;            // the motor's last step, on SYNC or on its own clock
  std::int64_t last_setpoints_ns = 0;       // the last complete setpoint set applied
  std::int64_t late_send_ns = INT64_MAX;    // when the held-back frames go out
  std::int64_t free_run_steps = 0;
  bool watchdog_before = false;
  int requests_seen = 0;
  bool pushing = false;  // a push step has set the motor's disturbance force
  const auto send = [&](const can::Frame& frame) {
    if (bus.send(frame)) {
      ++replies_sent;
    } else {
      ++replies_failed;
    }
  };
  // The drive's watchdog expiring is recorded once per expiry, with the time
  // since the last setpoint set was applied (CLOCK_MONOTONIC) to the drive's
  // time of the step in which it expired (`drive_ns`, the end of the period
  // the step stands for) and to when this process computed that step (`now_ns`).
  const auto note_watchdog = [&](std::int64_t drive_ns, std::int64_t now_ns) {
    const bool watchdog = motor.status().watchdog();
    if (watchdog && !watchdog_before && events != nullptr) {
      const sim::TruthState truth = motor.truth();
      std::fprintf(events,
                   "event=watchdog sync=%lld after_last_setpoints_s=%.6f computed_after_last_setpoints_s=%.6f "
                   "timeout_s=%.6f free_run_steps=%lld max_abs_current_A=%.6g enabled=%d\n",
                   static_cast<long long>(nodes.counters().syncs),
                   static_cast<double>(drive_ns - last_setpoints_ns) * 1e-9,
                   static_cast<double>(now_ns - last_setpoints_ns) * 1e-9, parameters.drive.watchdog_timeout_s,
                   static_cast<long long>(free_run_steps), truth.currents_A.cwiseAbs().maxCoeff(),
                   motor.status().enabled() ? 1 : 0);
      std::fflush(events);
    }
    watchdog_before = watchdog;
  };
  while (g_stop_signal.load(std::memory_order_relaxed) == 0) {
    std::int64_t now_ns = monotonic_ns();
    if (now_ns >= end_ns) break;
    for (const int requests = g_injection_requests.load(std::memory_order_relaxed); requests_seen < requests;
         ++requests_seen) {
      injector.request_next();
    }
    if (now_ns >= late_send_ns) {
      for (std::size_t k = 0; k < injected.late_count; ++k) send(injected.late[k]);
      injected.late_count = 0;
      late_send_ns = INT64_MAX;
    }
    // The drive's own clock: no SYNC for a while and the power stage on.
    const bool free_running = nodes.counters().syncs > 0 && motor.status().enabled() &&
                              now_ns - last_step_ns >= kFreeRunAfterPeriods * period_ns;
    if (free_running) {
      while (now_ns - last_step_ns >= period_ns && motor.status().enabled()) {
        motor.step(period_s);
        last_step_ns += period_ns;
        ++free_run_steps;
        note_watchdog(last_step_ns, now_ns);
      }
      if (!motor.status().enabled()) last_step_ns = now_ns;
    }
    std::int64_t deadline_ns = std::min({end_ns, now_ns + kMaxWait_ns, late_send_ns});
    if (nodes.counters().syncs > 0 && motor.status().enabled()) {
      deadline_ns = std::min(deadline_ns, last_step_ns + (free_running ? 1 : kFreeRunAfterPeriods) * period_ns);
    }
    if (!bus.receive(received, deadline_ns)) continue;
    now_ns = monotonic_ns();
    injector.observe(received.frame);
    const bool sync = received.frame.id == can::kSyncId;
    const sim::InjectionStep* fired = sync ? injector.on_sync() : nullptr;
    if (fired != nullptr && fired->kind == sim::InjectionKind::kDriveFault) motor.latch_internal_fault();
    if (fired != nullptr && fired->kind == sim::InjectionKind::kPush) {
      motor.set_disturbance_force_N(motor.truth().velocity_m_per_s > 0.0 ? -fired->value : fired->value);
      pushing = true;
    } else if (sync && pushing && (!injector.push_active() || !motor.status().enabled())) {
      motor.set_disturbance_force_N(0.0);
      pushing = false;
    }
    const std::int64_t applied_before = nodes.counters().setpoints_applied;
    const std::size_t count = nodes.on_frame(received.frame, replies);
    if (nodes.counters().setpoints_applied != applied_before) last_setpoints_ns = now_ns;
    if (sync) {
      last_step_ns = received.timestamp_ns;
      if (injected.late_count > 0) {  // a late frame not yet out goes before this SYNC's replies
        for (std::size_t k = 0; k < injected.late_count; ++k) send(injected.late[k]);
        injected.late_count = 0;
      }
      injector.transform(std::span<const can::Frame>(replies.data(), count), injected);
      for (std::size_t k = 0; k < injected.now_count; ++k) send(injected.now[k]);
      late_send_ns = injected.late_count > 0
                         ? received.timestamp_ns +
                               static_cast<std::int64_t>(sim::BusInjector::kLateFraction * static_cast<double>(period_ns))
                         : INT64_MAX;
      note_watchdog(last_step_ns, now_ns);
      if (fired != nullptr && events != nullptr) {
        std::fprintf(events, "event=inject sync=%lld step=%d kind=%s frames=%d value=%g\n",
                     static_cast<long long>(nodes.counters().syncs), injector.step_index() + 1, sim::name(fired->kind),
                     fired->frames, fired->value);
        std::fflush(events);
      }
    } else {
      for (std::size_t k = 0; k < count; ++k) send(replies[k]);
    }
  }
  if (events != nullptr) std::fclose(events);
  const double elapsed_s = static_cast<double>(monotonic_ns() - start_ns) * 1e-9;

  const int signal = g_stop_signal.load(std::memory_order_relaxed);
  const std::string why = signal == SIGINT ? "SIGINT" : signal == SIGTERM ? "SIGTERM" : "end of --duration-s";
  const sim::NodeCounters& c = nodes.counters();
  const sim::TruthState truth = motor.truth();
  std::printf("clm sim: stopped on %s after %.1f s on %s: %lld SYNCs, %lld setpoint sets applied, %lld frames rejected, "
              "%lld feedback values not encodable, %lld replies sent, %lld not sent, %llu error frames, %llu dropped; "
              "position %.6f m, drive %s%s\n",
              why.c_str(), elapsed_s, options.interface_name.c_str(), static_cast<long long>(c.syncs),
              static_cast<long long>(c.setpoints_applied), static_cast<long long>(c.frames_rejected),
              static_cast<long long>(c.feedback_not_encoded), static_cast<long long>(replies_sent),
              static_cast<long long>(replies_failed), static_cast<unsigned long long>(bus.error_frames()),
              static_cast<unsigned long long>(bus.dropped_frames()), truth.position_m,
              motor.status().enabled() ? "enabled" : "disabled", latched_fault_text(motor.status()).c_str());
  std::fflush(stdout);
}

}  // namespace

void add_sim(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "sim", "run the simulated motor as the drive and force-sensor CAN nodes on a SocketCAN interface (docs/hil.md)");
  auto options = std::make_shared<SimOptions>();
  sub->add_option("--can", options->interface_name, "SocketCAN interface, e.g. vcan0")->required();
  sub->add_option("--motor", options->motor_file, "simulated motor file (config/motor-sim.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--rate-hz", options->rate_hz, "SYNC rate of the daemon: the motor steps 1/rate per SYNC [Hz]")
      ->check(clm::positive_number())
      ->capture_default_str();
  sub->add_option("--duration-s", options->duration_s, "stop after this many seconds [s]; default: until SIGINT/SIGTERM")
      ->check(clm::positive_number());
  sub->add_option("--drive-node-id", options->drive_node_id, "CANopen node ID of the drive (the daemon's can.drive_node_id)")
      ->check(clm::in_range(1, 127))
      ->capture_default_str();
  sub->add_option("--force-sensor-node-id", options->force_sensor_node_id,
                  "CANopen node ID of the force sensor (the daemon's can.force_sensor_node_id); 0: no force sensor, "
                  "no force frame is sent")
      ->check(clm::in_range(0, 127))
      ->capture_default_str();
  sub->add_option("--inject", options->injection_plan,
                  "bus-side fault injection: steps fired one per SIGUSR1 at the next SYNC with the axis enabled, "
                  "e.g. drop-drive:3,late-drive:1,corrupt-reserved:1,corrupt-alive,corrupt-position,wrong-dlc:1,"
                  "duplicate:1,drop-force:3,drive-fault (docs/reliability.md)");
  sub->add_option("--event-log", options->event_log,
                  "write one line per injection fired and per drive watchdog expiry to this file");
  sub->callback([options] {
    if (!std::isfinite(options->rate_hz)) throw std::runtime_error("--rate-hz must be finite");
    run_sim(*options);
  });
}

}  // namespace clm::cli
