#pragma once
// The real-time set-up of clm-servod's loop thread, one step per function so
// main can apply them explicitly, in order, and decide what a failure means
// (ros2_control's pattern): lock memory, pin the loop thread to a CPU, give
// it SCHED_FIFO. Each step returns 0 or the errno it failed with; none
// throws, logs or exits.

#include <pthread.h>

#include <cstddef>
#include <string>

namespace clm::servod {

/// mlockall(MCL_CURRENT | MCL_FUTURE) for the whole process, so no page of
/// the loop is ever paged out or faulted in later. 0 or errno (ENOMEM: the
/// RLIMIT_MEMLOCK is too small, EPERM: no CAP_IPC_LOCK).
int lock_memory() noexcept;

/// Restricts `thread` to CPU `cpu` (0-based). 0 or errno (EINVAL: no such
/// CPU or not in this process's cpuset).
int pin_thread_to_cpu(pthread_t thread, int cpu) noexcept;

/// SCHED_FIFO at `priority` (1..99) for `thread`. 0 or errno (EPERM:
/// RLIMIT_RTPRIO below `priority` and no CAP_SYS_NICE, or a container that
/// refuses real-time scheduling; EINVAL: priority out of range).
int set_fifo_priority(pthread_t thread, int priority) noexcept;

/// Touches `bytes` of the calling thread's stack so that, with memory locked,
/// the cycle never takes a page fault growing it.
void prefault_stack(std::size_t bytes = 256 * 1024) noexcept;

/// What main does when a step fails: with require_realtime the daemon
/// refuses to start (exit 2), otherwise it warns and runs without the step.
struct RealtimeStepResult {
  bool fatal = false;
  std::string message;  ///< one line, without the program name; empty when the step succeeded
};

/// Judges step `step` (e.g. "SCHED_FIFO priority 80") that returned `error`.
RealtimeStepResult judge_realtime_step(const std::string& step, int error, bool require_realtime);

}  // namespace clm::servod
