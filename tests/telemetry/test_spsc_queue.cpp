#include <catch2/catch.hpp>

#include <cstdint>
#include <thread>

#include "daemon/telemetry/spsc_queue.hpp"
#include "support/allocation_counter.hpp"

using clm::telemetry::SpscQueue;

namespace {
constexpr std::int64_t kItems = 1'000'000;
}

TEST_CASE("SpscQueue refuses a capacity that is not a power of two", "[telemetry][spsc]") {
  CHECK_THROWS_AS(SpscQueue<int>(0), std::invalid_argument);
  CHECK_THROWS_AS(SpscQueue<int>(3), std::invalid_argument);
  CHECK_THROWS_WITH(SpscQueue<int>(100), "SpscQueue: capacity 100 is not a power of two");
  CHECK(SpscQueue<int>(1).capacity() == 1);
  CHECK(SpscQueue<int>(1024).capacity() == 1024);
}

TEST_CASE("SpscQueue accepts exactly its capacity, refuses the rest, and gives items back in order",
          "[telemetry][spsc]") {
  SpscQueue<std::int64_t> queue(8);
  std::int64_t refused = 0;
  for (std::int64_t i = 0; i < 20; ++i) {
    if (!queue.try_push(i)) ++refused;
  }
  CHECK(refused == 20 - 8);
  CHECK(queue.size_approx() == 8);
  std::int64_t item = -1;
  for (std::int64_t i = 0; i < 8; ++i) {
    REQUIRE(queue.try_pop(item));
    CHECK(item == i);
  }
  CHECK_FALSE(queue.try_pop(item));
  CHECK(item == 7);  // untouched by the failed pop
}

TEST_CASE("SpscQueue wraps around its ring many times without losing or reordering", "[telemetry][spsc]") {
  SpscQueue<std::int64_t> queue(4);
  std::int64_t next_in = 0, next_out = 0, item = 0;
  const auto pop_and_check = [&] {
    REQUIRE(queue.try_pop(item));
    REQUIRE(item == next_out++);
  };
  for (int round = 0; round < 10000; ++round) {
    const std::size_t pushes = 1 + round % 4;
    while (queue.size_approx() + pushes > queue.capacity()) pop_and_check();
    for (std::size_t i = 0; i < pushes; ++i) REQUIRE(queue.try_push(next_in++));
    for (int i = 0; i < round % 3 && queue.size_approx() > 0; ++i) pop_and_check();
  }
  while (next_out < next_in) pop_and_check();
  CHECK_FALSE(queue.try_pop(item));
  CHECK(next_in > 20000);
}

TEST_CASE("SpscQueue passes 1e6 items between two threads in order, none lost, when the producer waits for room",
          "[telemetry][spsc]") {
  SpscQueue<std::int64_t> queue(1024);
  std::int64_t full_retries = 0;
  std::thread producer([&] {
    for (std::int64_t i = 0; i < kItems; ++i) {
      while (!queue.try_push(i)) {
        ++full_retries;
        std::this_thread::yield();
      }
    }
  });
  std::int64_t expected = 0;
  std::int64_t out_of_order = 0;
  std::int64_t item = 0;
  while (expected < kItems) {
    if (queue.try_pop(item)) {
      if (item != expected) ++out_of_order;
      expected = item + 1;
    } else {
      std::this_thread::yield();
    }
  }
  producer.join();
  CHECK(out_of_order == 0);
  CHECK(expected == kItems);
  CHECK_FALSE(queue.try_pop(item));
  INFO("producer found the ring full " << full_retries << " times");
  SUCCEED();
}

TEST_CASE("SpscQueue between two threads: a producer that never waits loses only what it counted, order kept",
          "[telemetry][spsc]") {
  SpscQueue<std::int64_t> queue(256);
  std::int64_t dropped = 0;
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (std::int64_t i = 0; i < kItems; ++i) {
      if (!queue.try_push(i)) ++dropped;
    }
    done.store(true, std::memory_order_release);
  });
  std::int64_t received = 0, last = -1, out_of_order = 0, item = 0;
  while (true) {
    if (queue.try_pop(item)) {
      if (item <= last) ++out_of_order;
      last = item;
      ++received;
    } else if (done.load(std::memory_order_acquire)) {
      if (!queue.try_pop(item)) break;  // nothing pushed after done
      if (item <= last) ++out_of_order;
      last = item;
      ++received;
    }
  }
  producer.join();
  CHECK(out_of_order == 0);
  CHECK(received + dropped == kItems);
}

TEST_CASE("SpscQueue push and pop do not allocate", "[telemetry][spsc]") {
  SpscQueue<std::int64_t> queue(64);
  std::int64_t item = 0;
  const clm::test::AllocationScope scope;
  for (std::int64_t i = 0; i < 100000; ++i) {
    (void)queue.try_push(i);
    if (i % 3 != 0) (void)queue.try_pop(item);
  }
  CHECK(scope.allocations() == 0);
}
