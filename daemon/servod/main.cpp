// clm-servod: the servo daemon of a coreless linear motor (docs/servod.md).
//
// Threads, all created here:
//   main       start-up, the loop thread's real-time set-up, signals
//              (SIGINT, SIGTERM, SIGHUP and SIGQUIT are blocked everywhere
//              and taken with sigtimedwait here: no asynchronous handler),
//              shutdown;
//   loop       the servo cycle: a std::thread held at a start gate until
//              main has pinned it (loop.cpu) and given it SCHED_FIFO
//              (loop.priority), then ServoDaemon::run_realtime, or
//              run_cycles at full speed on the virtual clock;
//   commands   CommandServer: LCM commands → command authority →
//              ServoDaemon::submit → acks;
//   receiver   TelemetryPublisher's receiver: reads the LCM group with a
//              socket of its own, checks every datagram, latches stop,
//              quick stop and disable for the loop (ServoDaemon::
//              request_safety) and queues the rest for the command thread;
//   loader     FileLoader: reads the files commands name, one at a time;
//   telemetry  TelemetryPublisher's own thread (LCM out);
//   monitor    ServiceMonitor: WATCHDOG=1 while the loop's cycle counter
//              advances, STATUS= lines (systemd, Type=notify).
// Only the loop thread runs with real-time priority.
//
// Exit status (config/command_line.hpp): 0 after a clean shutdown, 2 on a
// bad command line or when start-up fails (one line on stderr), 1 when the
// loop thread failed while running.
//
// Shutdown (docs/servod.md, "Shutdown"): on a stop signal main sets the
// daemon's disable request, which the loop honours at its next cycle (not
// through the command queue, whose one producer is the command thread); it
// waits for the disabled state and a few cycles of zero setpoints, then stops
// the command thread, the loop, the monitor and telemetry. A file still being
// loaded is waited for at most kLoaderWait_s and then left: the process exits
// without running the loader's destructors.

#include <pthread.h>
#include <signal.h>
#include <time.h>

#include <cstdlib>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <exception>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "clm_version.hpp"
#include "config/command_key.hpp"
#include "config/command_line.hpp"
#include "config/regular_file.hpp"
#include "daemon/servod/axis_presence.hpp"
#include "daemon/servod/axis_wiring.hpp"
#include "daemon/servod/command_server.hpp"
#include "daemon/servod/file_loader.hpp"
#include "daemon/servod/loop_health.hpp"
#include "daemon/servod/realtime.hpp"
#include "daemon/servod/sd_notify.hpp"
#include "daemon/servod/servo_daemon.hpp"
#include "daemon/servod/servod_config.hpp"
#include "daemon/servod/telemetry_bridge.hpp"
#include "daemon/telemetry/telemetry.hpp"

namespace {

using namespace clm;
using Clock = std::chrono::steady_clock;

void warn(const std::string& message) { std::fprintf(stderr, "clm-servod: warning: %s\n", message.c_str()); }
void note(const std::string& message) { std::fprintf(stderr, "clm-servod: %s\n", message.c_str()); }

std::string format_seconds(double seconds) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g s", seconds);
  return text;
}

/// Cycles run with zero setpoints after the disable at shutdown, so the
/// drives see the axis disabled before the bus goes quiet.
constexpr std::int64_t kShutdownCycles = 10;

/// How long shutdown waits for a file being loaded before leaving it.
constexpr double kLoaderWait_s = 0.2;

const char* signal_name(int signal) {
  switch (signal) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    case SIGQUIT: return "SIGQUIT";
    default: return "a signal";
  }
}

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

/// How long start-up waits for the first cycle before giving up.
constexpr double kFirstCycleTimeout_s = 5.0;
/// How long the start-up timing warning asks the watchdog and the overrun
/// limit to hold at the measured timing [s] (servo::judge_timing_margin).
constexpr double kTimingHorizon_s = 3600.0;

/// Waits until `done()` or `timeout_s`; true if done.
template <typename Done>
bool wait_for(Done done, double timeout_s) {
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  while (!done()) {
    if (Clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

/// Sleeps until a stop signal (blocked in every thread), the deadline, or
/// `loop_exited`. Returns the signal number, or 0.
// Returns the stop signal, or 0 at the deadline or when the loop has exited.
// SIGUSR1, when in `signals`, fires the next step of the simulated motor's
// fault-injection plan and the wait goes on.
int wait_for_stop(const sigset_t& signals, std::optional<Clock::time_point> deadline, const std::atomic<bool>& loop_exited,
                  sim::InProcessBus* injection_bus) {
  while (!loop_exited.load(std::memory_order_acquire)) {
    if (deadline && Clock::now() >= *deadline) return 0;
    const timespec timeout{0, 20'000'000};  // 20 ms: bounds how late the deadline and a dead loop are seen
    const int signal = ::sigtimedwait(&signals, nullptr, &timeout);
    if (signal == SIGUSR1 && injection_bus != nullptr) {
      injection_bus->request_next_step();
      continue;
    }
    if (signal > 0) return signal;
  }
  return 0;
}

int run(const std::string& config_path, double duration_s) {
  const servod::ServodConfig config = servod::load_servod_config(config_path);
  // The operators' key: every command but a stop must carry its mac, and
  // every message published carries it (docs/servod.md, "Who may command the axis").
  std::optional<HmacSha256> key;
  if (config.telemetry.enabled) {
    try {
      key = load_command_key(config.commands.key_file);
    } catch (const FileError& e) {
      throw FileError(config.origin + ": commands.key_file: " + e.what());
    }
  }
  // This run's identity, in every status and ack; no other daemon may drive the axis on the URL.
  const std::int64_t session = servod::draw_session_id();
  if (config.telemetry.enabled) {
    servod::require_axis_free(config.telemetry.lcm_url, config.axis_name, session, config.telemetry.status_rate_hz, *key);
  }

  // The stop signals go to main's sigtimedwait only: block them before any
  // thread exists, so every thread inherits the mask. SIGHUP and SIGQUIT
  // stop the daemon like SIGTERM (their default actions would end it with
  // the axis enabled).
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  for (const int signal : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) sigaddset(&stop_signals, signal);
  // With can.sim_fault_plan, SIGUSR1 fires its next step (taken here too).
  if (!config.can.sim_fault_plan.empty()) sigaddset(&stop_signals, SIGUSR1);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  const servod::SystemdNotifier notifier = servod::SystemdNotifier::from_environment();
  const double watchdog_period_s = servod::watchdog_period_from_environment();

  // The bus can.interface names (SocketCAN, or the embedded simulated motor)
  // and the daemon on it.
  servod::WiredAxis axis(config);
  servod::ServoDaemon& daemon = axis.daemon;

  std::unique_ptr<telemetry::TelemetryPublisher> publisher;
  std::unique_ptr<servod::TelemetryBridge> bridge;
  if (config.telemetry.enabled) {
    telemetry::TelemetryConfig telemetry_config;
    telemetry_config.lcm_url = config.telemetry.lcm_url;
    telemetry_config.state_decimation = config.telemetry.state_decimation;
    telemetry_config.axis = config.axis_name;
    telemetry_config.session = session;
    telemetry_config.key = key;
    publisher = std::make_unique<telemetry::TelemetryPublisher>(telemetry_config);
    bridge = std::make_unique<servod::TelemetryBridge>(*publisher, daemon);
  }
  servod::LoopHealth health(bridge.get());
  daemon.set_observer(&health);
  // Files named by commands are read on the loader thread.
  servod::FileLoader loader;
  daemon.set_file_loader(&loader);

  // ---- the loop thread, held at its start gate --------------------------
  std::promise<bool> gate;
  std::atomic<bool> loop_stop{false};
  std::atomic<bool> loop_exited{false};
  std::exception_ptr loop_error;
  const bool realtime_clock = config.loop.clock == servod::ClockMode::kRealtime;
  std::thread loop([&, released = gate.get_future()]() mutable {
    if (released.get()) {
      try {
        if (realtime_clock) {
          servod::prefault_stack();
          daemon.run_realtime(loop_stop);
        } else {
          while (!loop_stop.load(std::memory_order_acquire)) daemon.run_cycles(100);
        }
      } catch (...) {
        loop_error = std::current_exception();
      }
    }
    loop_exited.store(true, std::memory_order_release);
  });
  // Whatever throws from here on leaves through this: the loop thread is
  // released (or refused) and joined before anything it uses goes away.
  bool gate_open = false;
  struct LoopJoiner {
    std::function<void()> join;
    ~LoopJoiner() { join(); }
  } joiner{[&] {
    if (!loop.joinable()) return;
    loop_stop.store(true, std::memory_order_release);
    if (!gate_open) gate.set_value(false);
    gate_open = true;
    loop.join();
  }};

  // ---- real-time set-up of the loop thread -------------------------------
  // Steps in this order: memory first (it also locks the stacks of the
  // threads created so far), then the CPU, then the scheduler. A failed step
  // is fatal with loop.require_realtime, else a warning. On the virtual clock
  // the loop never sleeps, so SCHED_FIFO would starve the other threads on
  // its CPU: the set-up is skipped.
  if (realtime_clock) {
    const auto step = [&](const std::string& name, int error) {
      const auto result = servod::judge_realtime_step(name, error, config.loop.require_realtime);
      if (result.message.empty()) return;
      if (result.fatal) throw std::runtime_error(result.message);
      warn(result.message);
    };
    if (config.loop.lock_memory) step("mlockall(MCL_CURRENT | MCL_FUTURE)", servod::lock_memory());
    if (config.loop.cpu >= 0) {
      step("pinning the loop thread to CPU " + std::to_string(config.loop.cpu),
           servod::pin_thread_to_cpu(loop.native_handle(), config.loop.cpu));
    }
    if (config.loop.priority > 0) {
      step("SCHED_FIFO priority " + std::to_string(config.loop.priority) + " for the loop thread",
           servod::set_fifo_priority(loop.native_handle(), config.loop.priority));
    }
  }

  // The files the configuration names, each inside commands.file_directories
  // (checked when the configuration was read).
  std::string files;
  for (const auto& [name, path] : {std::pair{"calibration_file", &config.commutation.calibration_file},
                                  std::pair{"pgnn_model_file", &config.commutation.pgnn_model_file},
                                  std::pair{"spline_model_file", &config.commutation.spline_model_file},
                                  std::pair{"feedforward_file", &config.feedforward_file}}) {
    if (!path->empty()) files += std::string(files.empty() ? "" : ", ") + name + " " + *path;
  }
  note("files of the configuration: " + (files.empty() ? std::string("none") : files));

  // ---- start ------------------------------------------------------------
  std::optional<servod::CommandServer> commands;
  if (publisher) {
    commands.emplace(*publisher, daemon,
                     servod::CommandGateSettings{config.axis_name, session, config.commands.max_age_s,
                                                 config.commands.control_lease_s, config.commands.deadman_timeout_s});
    bridge->set_authority(&*commands);
    // Stop, quick stop and disable: from the receiver straight to the loop.
    publisher->set_safety_latch(*commands);
  }
  // The receiver calls the latch: on any way out of here the publisher's
  // threads stop before the command server is destroyed.
  const struct PublisherStop {
    telemetry::TelemetryPublisher* publisher;
    ~PublisherStop() {
      if (publisher != nullptr) publisher->stop();
    }
  } publisher_stop{publisher.get()};
  if (publisher) publisher->start();
  if (commands) commands->start();
  gate.set_value(true);
  gate_open = true;

  if (!wait_for([&] { return daemon.cycles_done() > 0 || loop_exited.load(); }, kFirstCycleTimeout_s) ||
      daemon.cycles_done() == 0) {
    throw std::runtime_error("the loop ran no cycle within " + std::to_string(kFirstCycleTimeout_s) + " s");
  }
  servod::ServiceMonitor monitor(notifier, watchdog_period_s, [&] { return daemon.cycles_done(); },
                                 [&] {
                                   // Every fault latch goes to the journal (stderr), from this thread.
                                   const std::string latched = health.take_fault_report(config.servo.period_s);
                                   if (!latched.empty()) warn(latched);
                                   // Once, after the first second: the timing margin of the
                                   // drive's watchdog and the overrun limit (docs/servod.md).
                                   const std::string timing = health.take_timing_warning(
                                       config.servo.period_s, {config.motor.drive_watchdog_timeout_s,
                                                               config.servo.overrun_limit, kTimingHorizon_s});
                                   if (!timing.empty()) warn(timing);
                                   // Refused stops, quick stops and disables, rate-limited.
                                   if (publisher) {
                                     for (const std::string& line : publisher->safety_refusals().take_lines(
                                              telemetry::wall_clock_utime())) {
                                       warn(line);
                                     }
                                   }
                                   return health.status_line();
                                 });
  notifier.notify("READY=1");
  monitor.start();  // sends the first STATUS= at once
  note(std::string("running: ") + std::to_string(static_cast<int>(config.loop.rate_hz)) + " Hz on the " +
       (realtime_clock ? "real-time" : "virtual") + " clock, CAN " + config.can.interface + ", telemetry " +
       (config.telemetry.enabled ? config.telemetry.lcm_url : std::string("off")) +
       (watchdog_period_s > 0.0 ? ", systemd watchdog every " + format_seconds(0.5 * watchdog_period_s) : "") +
       (config.can.sim_fault_plan.empty() ? ""
                                          : ", fault injection: " + std::to_string(config.can.sim_fault_plan.size()) +
                                                " steps, one per SIGUSR1"));

  std::optional<Clock::time_point> deadline;
  if (duration_s > 0.0) {
    deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(duration_s));
  }
  const int signal = wait_for_stop(stop_signals, deadline, loop_exited,
                                   config.can.sim_fault_plan.empty() ? nullptr : axis.in_process_bus());

  // ---- shutdown: disable first, then join -----------------------------------
  const std::int64_t cycles_at_stop = daemon.cycles_done();
  const Clock::time_point stop_time = Clock::now();
  daemon.request_disable();  // the loop disables at its next cycle
  notifier.notify("STOPPING=1");
  if (signal != 0) note(std::string("stopping on ") + signal_name(signal));
  if (!loop_exited.load(std::memory_order_acquire)) {
    const std::int64_t first = daemon.cycles_done();
    // A generous bound for a slow loop; normally two cycles.
    const double bound_s = 1.0 + 2.0 * static_cast<double>(kShutdownCycles) * config.servo.period_s;
    if (wait_for([&] { return (daemon.cycles_done() >= first + 2 && health.state() != servo::ServoState::kEnabled) ||
                              loop_exited.load(); },
                 bound_s)) {
      // The loop's own record: the cycle that disabled the axis, and when.
      const std::int64_t after = daemon.disabled_after_cycles();
      if (after >= 0) {
        const double ms = 1e-6 * static_cast<double>(daemon.disabled_at_ns() -
                                                      std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                          stop_time.time_since_epoch()).count());
        char text[112];
        std::snprintf(text, sizeof text, "axis disabled %.1f ms after the stop request, in cycle %lld after it",
                      ms, static_cast<long long>(after - cycles_at_stop + 1));
        note(text);
      }
    } else {
      warn("the axis did not report disabled within " + std::to_string(bound_s) + " s of the stop request");
    }
    // Disabled cycles send zero setpoints: the drives see them before the bus goes quiet.
    const std::int64_t until = daemon.cycles_done() + kShutdownCycles;
    wait_for([&] { return daemon.cycles_done() >= until || loop_exited.load(); }, bound_s);
  }
  if (commands) commands->stop();
  loop_stop.store(true, std::memory_order_release);
  loop.join();
  monitor.stop();
  const bool load_left = !loader.wait_idle(kLoaderWait_s);
  if (load_left) warn("a file was still being loaded at shutdown; left unfinished");
  {
    // One line for benchmarks and logs: the loop's timing over the whole run.
    const servod::LoopTiming& timing = daemon.timing();
    const auto us = [](double s) { return s * 1e6; };
    std::fprintf(stderr,
                 "clm-servod: timing: cycles %lld, wake-up latency p50 %.1f us p99 %.1f us p99.9 %.1f us max %.1f us, "
                 "compute p50 %.1f us p99 %.1f us max %.1f us (cycle %lld), missed deadlines %lld, late setpoints %lld\n",
                 static_cast<long long>(daemon.cycles_done()), us(timing.wakeup_latency.quantile_s(0.5)),
                 us(timing.wakeup_latency.quantile_s(0.99)), us(timing.wakeup_latency.quantile_s(0.999)),
                 us(timing.wakeup_latency.max_s()), us(timing.compute_time.quantile_s(0.5)),
                 us(timing.compute_time.quantile_s(0.99)), us(timing.compute_time.max_s()),
                 static_cast<long long>(timing.longest_compute_cycle),
                 static_cast<long long>(timing.missed_deadlines), static_cast<long long>(timing.late_setpoints));
  }
  daemon.set_observer(nullptr);
  if (publisher) {
    publisher->stop();
    // Where telemetry went: a receiver that misses states can tell a drop in
    // the daemon's queues from a send LCM refused from a loss after sending.
    const telemetry::TelemetryCounters counters = publisher->counters();
    std::fprintf(stderr, "clm-servod: telemetry: published %lld, publish failures %lld, dropped in queues %lld\n",
                 static_cast<long long>(counters.published), static_cast<long long>(counters.publish_failures),
                 static_cast<long long>(counters.telemetry_dropped()));
  }
  {
    char text[64];
    std::snprintf(text, sizeof text, "exiting %.1f ms after the stop request", 1e3 * seconds_since(stop_time));
    note(text);
  }
  if (load_left) {
    // The loader thread still reads a file and uses the daemon: exit without
    // destroying either (no stack unwinding, no static destructors).
    std::fflush(nullptr);
    std::_Exit(loop_error ? 1 : 0);
  }
  if (loop_error) {
    try {
      std::rethrow_exception(loop_error);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "clm-servod: error: the loop stopped: %s\n", e.what());
    }
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"clm-servod: real-time servo daemon for coreless linear motors (docs/servod.md)", "clm-servod"};
  app.set_version_flag("--version", std::string("clm-servod ") + CLM_SERVO_VERSION);
  std::string config_path;
  double duration_s = 0.0;
  app.add_option("--config", config_path, "configuration file (YAML, e.g. config/servod.yaml)")->required();
  app.add_option("--duration-s", duration_s,
                 "stop cleanly after this many seconds [s]; default: run until SIGINT, SIGTERM, SIGHUP or SIGQUIT")
      ->check(clm::positive_number());
  // A failed start-up is bad input (exit status 2, RestartPreventExitStatus=2); run() returns 1 itself when the
  // loop thread failed while running.
  return clm::run_command_line(app, argc, argv, [&] { return run(config_path, duration_s); });
}
