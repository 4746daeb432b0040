#pragma once
// The coil sets of a motor are independent identification problems (each its
// own data, seed and solver): the tools fit them side by side, one thread
// each. Results never depend on the order in which they finish.

#include <cstddef>
#include <functional>
#include <future>
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

}  // namespace clm::data
