// The loop thread's real-time set-up steps and what main makes of a failure.
#include <catch2/catch.hpp>

#include <pthread.h>
#include <sched.h>

#include <cerrno>
#include <thread>

#include "daemon/servod/realtime.hpp"

using namespace clm::servod;

TEST_CASE("A thread is pinned to a CPU it may run on and refused a CPU that does not exist", "[servod][realtime]") {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  REQUIRE(sched_getaffinity(0, sizeof(allowed), &allowed) == 0);
  int first = -1;
  for (int cpu = 0; cpu < CPU_SETSIZE && first < 0; ++cpu) first = CPU_ISSET(cpu, &allowed) ? cpu : -1;
  REQUIRE(first >= 0);

  int pinned = -1;
  int running_on = -1;
  std::thread worker([&] {
    pinned = pin_thread_to_cpu(pthread_self(), first);
    running_on = sched_getcpu();
  });
  worker.join();
  CHECK(pinned == 0);
  CHECK(running_on == first);
  CHECK(pin_thread_to_cpu(pthread_self(), -1) == EINVAL);
  CHECK(pin_thread_to_cpu(pthread_self(), CPU_SETSIZE) == EINVAL);
}

TEST_CASE("SCHED_FIFO outside 1..99 is refused before asking the kernel", "[servod][realtime]") {
  CHECK(set_fifo_priority(pthread_self(), 0) == EINVAL);
  CHECK(set_fifo_priority(pthread_self(), 100) == EINVAL);
}

TEST_CASE("SCHED_FIFO is granted or refused with an errno, never silently", "[servod][realtime]") {
  // Containers often refuse real-time scheduling (EPERM); either outcome is
  // reported, and a granted one is what the thread then has.
  int result = -1, policy = -1;
  sched_param parameters{};
  std::thread worker([&] {
    result = set_fifo_priority(pthread_self(), 1);
    pthread_getschedparam(pthread_self(), &policy, &parameters);
  });
  worker.join();
  if (result == 0) {
    CHECK(policy == SCHED_FIFO);
    CHECK(parameters.sched_priority == 1);
  } else {
    CHECK(result == EPERM);
    CHECK(policy == SCHED_OTHER);
  }
}

TEST_CASE("A failed step is fatal with require_realtime and a warning without, naming the step and the errno",
          "[servod][realtime]") {
  const auto ok = judge_realtime_step("mlockall(MCL_CURRENT | MCL_FUTURE)", 0, true);
  CHECK_FALSE(ok.fatal);
  CHECK(ok.message.empty());

  const auto fatal = judge_realtime_step("SCHED_FIFO priority 80 for the loop thread", EPERM, true);
  CHECK(fatal.fatal);
  CHECK(fatal.message == "SCHED_FIFO priority 80 for the loop thread failed: Operation not permitted "
                         "(loop.require_realtime is true)");

  const auto warning = judge_realtime_step("mlockall(MCL_CURRENT | MCL_FUTURE)", ENOMEM, false);
  CHECK_FALSE(warning.fatal);
  CHECK(warning.message == "mlockall(MCL_CURRENT | MCL_FUTURE) failed: Cannot allocate memory; running without it "
                           "(loop.require_realtime is false)");
}

TEST_CASE("Prefaulting the stack returns", "[servod][realtime]") {
  std::thread worker([] { prefault_stack(); });
  worker.join();
  SUCCEED();
}
