#pragma once
// The coil sets of a motor are independent identification problems (each its
// own data, seed and solver), and so are the trials of a capacity grid: the
// tools fit them side by side. Results never depend on the order in which
// they finish, nor on which thread ran them.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <functional>
#include <future>
#include <thread>
#include <vector>

namespace clm::data {

/// Runs body(l) for l = 0..count−1, each on its own thread, and waits for
/// all of them; then rethrows the first exception in coil-set order.
inline void for_each_coil_set(std::size_t count, const std::function<void(std::size_t)>& body) {
  std::vector<std::future<void>> running;
  running.reserve(count);
  for (std::size_t l = 0; l < count; ++l) running.push_back(std::async(std::launch::async, body, l));
  for (auto& task : running) task.wait();
  for (auto& task : running) task.get();
}

/// Runs task(k) for k = 0..count−1 on as many threads as the machine has
/// cores (at most `count`), each thread taking the next k until none is
/// left, and waits for all of them; then rethrows the first exception in
/// task order. `task` must write only what belongs to its k.
inline void for_each_task(std::size_t count, const std::function<void(std::size_t)>& task) {
  const std::size_t workers = std::min<std::size_t>(count, std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::exception_ptr> failures(count);
  std::atomic<std::size_t> next{0};
  const auto work = [&] {
    for (std::size_t k = next++; k < count; k = next++) {
      try {
        task(k);
      } catch (...) {
        failures[k] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> threads;
  for (std::size_t w = 1; w < workers; ++w) threads.emplace_back(work);
  work();
  for (auto& thread : threads) thread.join();
  for (const auto& failure : failures) {
    if (failure) std::rethrow_exception(failure);
  }
}

}  // namespace clm::data
