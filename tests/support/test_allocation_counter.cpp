// The allocation counter itself: it must see every operator new of the
// calling thread, also in the sanitizer build (docs/fuzzing.md), or every
// "does not allocate" test would pass without counting anything.
#include <catch2/catch.hpp>

#include <cstdint>
#include <new>
#include <thread>
#include <vector>

#include "support/allocation_counter.hpp"

namespace {
// Stores keep the allocations observable, so the compiler cannot elide them.
void* volatile g_sink = nullptr;
struct alignas(64) CacheLine {
  double values[8];
};
}  // namespace

TEST_CASE("the allocation counter counts every operator new of this thread and no other", "[support][unit]") {
  // Counts are read into locals and checked at the end: Catch2 may allocate
  // while it reports an assertion (with -s, for instance).
  std::size_t counts[7] = {};
  bool aligned = false;
  {
    clm::test::AllocationScope scope;
    counts[0] = scope.allocations();

    g_sink = ::operator new(16);
    ::operator delete(g_sink);
    counts[1] = scope.allocations();

    g_sink = ::operator new[](32);
    ::operator delete[](g_sink);
    counts[2] = scope.allocations();

    g_sink = ::operator new(64, std::align_val_t{64});
    aligned = reinterpret_cast<std::uintptr_t>(g_sink) % 64 == 0;
    ::operator delete(g_sink, std::align_val_t{64});
    counts[3] = scope.allocations();

    g_sink = ::operator new(8, std::nothrow);
    ::operator delete(g_sink);
    counts[4] = scope.allocations();

    {
      std::vector<CacheLine> lines(3);
      g_sink = lines.data();
    }
    counts[5] = scope.allocations();

    // Another thread's allocations are its own (the cycle's tests rely on
    // it); std::thread allocates its state in this thread: one.
    std::thread other([] {
      for (int i = 0; i < 10; ++i) {
        g_sink = ::operator new(16);
        ::operator delete(g_sink);
      }
    });
    other.join();
    counts[6] = scope.allocations();
  }
  CHECK(counts[0] == 0);
  CHECK(counts[1] == 1);
  CHECK(counts[2] == 2);
  CHECK(counts[3] == 3);
  CHECK(aligned);
  CHECK(counts[4] == 4);
  CHECK(counts[5] == 5);
  CHECK(counts[6] - counts[5] <= 1);
}
