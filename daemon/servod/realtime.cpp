#include "daemon/servod/realtime.hpp"

#include <sched.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>

namespace clm::servod {

int lock_memory() noexcept { return ::mlockall(MCL_CURRENT | MCL_FUTURE) == 0 ? 0 : errno; }

int pin_thread_to_cpu(pthread_t thread, int cpu) noexcept {
  if (cpu < 0 || cpu >= CPU_SETSIZE) return EINVAL;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return ::pthread_setaffinity_np(thread, sizeof(set), &set);  // returns the error, does not set errno
}

int set_fifo_priority(pthread_t thread, int priority) noexcept {
  if (priority < sched_get_priority_min(SCHED_FIFO) || priority > sched_get_priority_max(SCHED_FIFO)) return EINVAL;
  sched_param parameters{};
  parameters.sched_priority = priority;
  return ::pthread_setschedparam(thread, SCHED_FIFO, &parameters);
}

void prefault_stack(std::size_t bytes) noexcept {
  constexpr std::size_t kChunk = 4096;
  // A volatile pointer keeps the compiler from dropping the writes.
  auto* volatile stack = static_cast<unsigned char*>(__builtin_alloca(bytes));
  for (std::size_t i = 0; i < bytes; i += kChunk) stack[i] = 0;
}

RealtimeStepResult judge_realtime_step(const std::string& step, int error, bool require_realtime) {
  RealtimeStepResult result;
  if (error == 0) return result;
  result.fatal = require_realtime;
  char buffer[256];
  const char* reason = ::strerror_r(error, buffer, sizeof(buffer));  // GNU variant: returns the text
  result.message = step + " failed: " + reason +
                   (require_realtime ? " (loop.require_realtime is true)" : "; running without it (loop.require_realtime is false)");
  return result;
}

}  // namespace clm::servod
