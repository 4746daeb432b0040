// ServoDaemon's loop: one cycle on the bus (commands between cycles, the
// bus clock, SYNC, feedback until the receive window closes, setpoints that
// never outlive their cycle), the virtual and the real-time clock, and the
// disable request of a stop signal. The command path and the files are in
// servo_daemon.cpp.
#include <time.h>

#include "daemon/servod/servo_daemon.hpp"
#include "daemon/servod/wakeup_schedule.hpp"

namespace clm::servod {
namespace {

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleep_until(std::int64_t time_ns) noexcept {
  timespec ts{};
  ts.tv_sec = time_ns / 1'000'000'000;
  ts.tv_nsec = time_ns % 1'000'000'000;
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace

void ServoDaemon::honour_disable_request() noexcept {
  if (!disable_requested_.load(std::memory_order_acquire)) return;
  cycle_->execute({.kind = servo::CommandKind::kDisable});
  if (disabled_after_cycles_.load(std::memory_order_relaxed) < 0) {
    disabled_at_ns_.store(monotonic_ns(), std::memory_order_release);
    disabled_after_cycles_.store(cycles_done_.load(std::memory_order_relaxed), std::memory_order_release);
  }
}

void ServoDaemon::one_cycle(const servo::CycleStart& start, std::int64_t deadline_ns, double time_s,
                            std::int64_t next_sync_ns, bool realtime) noexcept {
  drain_commands();
  clock_->advance_to(start.sync_time_ns);
  const can::Frame sync = cycle_->begin_cycle(start);
  answer_offer();
  bool send_failed = !bus_->send(sync);
  drivers::ReceivedFrame received;
  while (!cycle_->feedback_complete() && bus_->receive(received, deadline_ns)) cycle_->on_frame(received);
  // A bus fault known before the setpoints are built already zeroes this
  // cycle's setpoints; a failing setpoint send is reported after them.
  const auto frames = cycle_->end_cycle(time_s, {bus_->state(), send_failed});
  // Setpoints never outlive their cycle: past the next SYNC they are dropped.
  if (realtime && monotonic_ns() >= next_sync_ns) {
    ++timing_.late_setpoints;
  } else {
    for (const auto& frame : frames) send_failed = !bus_->send(frame) || send_failed;
  }
  cycle_->sent({bus_->state(), send_failed});
  mirror_state();
  if (observer_ != nullptr) observer_->on_cycle(*cycle_, timing_);
  cycles_done_.fetch_add(1, std::memory_order_release);
}

void ServoDaemon::run_cycles(std::int64_t cycles) {
  for (std::int64_t k = 0; k < cycles; ++k) run_cycle_after(0.0, false);
}

void ServoDaemon::run_cycle_after(double wakeup_gap_s, bool previous_overran) {
  const auto period_ns = static_cast<std::int64_t>(config_.servo.period_s * 1e9);
  virtual_time_ns_ += period_ns;
  one_cycle({virtual_time_ns_, wakeup_gap_s, previous_overran}, virtual_time_ns_ + period_ns / 2,
            static_cast<double>(virtual_time_ns_) * 1e-9, virtual_time_ns_ + period_ns, false);
}

std::int64_t ServoDaemon::run_until_idle(std::int64_t max_cycles) {
  std::int64_t done = 0;
  // One cycle first so a freshly posted program is adopted.
  while (done < max_cycles) {
    run_cycles(1);
    ++done;
    if (cycle_->mailbox().at_rest()) break;
  }
  return done;
}

void ServoDaemon::run_realtime(const std::atomic<bool>& stop) {
  const auto period_ns = static_cast<std::int64_t>(config_.servo.period_s * 1e9);
  const auto window_ns = static_cast<std::int64_t>(config_.loop.receive_window_fraction * static_cast<double>(period_ns));
  const std::int64_t start_ns = monotonic_ns();
  WakeupSchedule schedule(start_ns + period_ns, period_ns);
  std::int64_t previous_wake = start_ns;
  bool overran = false;
  while (!stop.load(std::memory_order_acquire)) {
    const std::int64_t planned = schedule.next_ns();
    sleep_until(planned);
    const std::int64_t wake = monotonic_ns();
    timing_.wakeup_latency.add(static_cast<double>(wake - planned) * 1e-9);
    const servo::CycleStart start{wake, static_cast<double>(wake - previous_wake) * 1e-9, overran};
    previous_wake = wake;
    one_cycle(start, planned + window_ns, static_cast<double>(planned - start_ns) * 1e-9, planned + period_ns, true);
    const std::int64_t done = monotonic_ns();
    const double compute_s = static_cast<double>(done - wake) * 1e-9;
    if (compute_s > timing_.compute_time.max_s()) timing_.longest_compute_cycle = cycle().record().cycle;
    timing_.compute_time.add(compute_s);
    const std::int64_t missed = schedule.advance(done);
    timing_.missed_deadlines += missed;
    overran = missed > 0;
  }
}

}  // namespace clm::servod
