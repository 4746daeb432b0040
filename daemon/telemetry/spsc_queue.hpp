#pragma once
// A lock-free ring for exactly one producer thread and one consumer thread,
// the hand-over between the real-time cycle and everything else (style
// rule 3). Storage is allocated once at construction; push and pop never
// allocate, lock, block or throw. A full ring refuses the item and the
// producer counts the drop: a slow consumer can never delay the producer.

#include <atomic>
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace clm::telemetry {

/// Cache-line size on x86-64 and most ARM cores [bytes]. A constant, not
/// std::hardware_destructive_interference_size, whose value may differ
/// between compilers (GCC warns about using it in a header).
inline constexpr std::size_t kCacheLineBytes = 64;

template <typename T>
class SpscQueue {
  static_assert(std::is_nothrow_default_constructible_v<T>, "slots are constructed up front");
  static_assert(std::is_nothrow_copy_assignable_v<T>, "try_push copies and must not throw");

 public:
  using value_type = T;

  /// A ring of `capacity` slots; throws std::invalid_argument unless
  /// `capacity` is a power of two ≥ 1. Allocates here, never again.
  explicit SpscQueue(std::size_t capacity)
      : capacity_(capacity), mask_(capacity - 1), slots_(checked_allocation(capacity)) {}

  SpscQueue(const SpscQueue&) = delete;
  SpscQueue& operator=(const SpscQueue&) = delete;

  /// Producer only. Copies `item` into the ring; false (item not queued) when
  /// the ring is full.
  bool try_push(const T& item) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail - head_cache_ == capacity_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail - head_cache_ == capacity_) return false;
    }
    slots_[tail & mask_] = item;
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Consumer only. Moves the oldest item into `out`; false (out untouched)
  /// when the ring is empty.
  bool try_pop(T& out) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_cache_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head == tail_cache_) return false;
    }
    out = slots_[head & mask_];
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  std::size_t capacity() const noexcept { return capacity_; }

  /// Items queued at some instant during the call; exact only when neither
  /// side is running.
  std::size_t size_approx() const noexcept {
    const std::size_t head = head_.load(std::memory_order_acquire);
    const std::size_t tail = tail_.load(std::memory_order_acquire);
    return tail - head;
  }

 private:
  static std::unique_ptr<T[]> checked_allocation(std::size_t capacity) {
    if (capacity == 0 || (capacity & (capacity - 1)) != 0) {
      throw std::invalid_argument("SpscQueue: capacity " + std::to_string(capacity) + " is not a power of two");
    }
    return std::make_unique<T[]>(capacity);
  }

  const std::size_t capacity_;
  const std::size_t mask_;
  const std::unique_ptr<T[]> slots_;
  // Indices count items ever pushed/popped (64 bits never wrap in practice);
  // slot = index & mask_. Each side's index and its private copy of the
  // other side's index share one cache line, owned by that side, so producer
  // and consumer do not false-share
  // (alignas also rounds the object's size up, padding the last line).
  alignas(kCacheLineBytes) std::atomic<std::size_t> tail_{0};  // written by the producer
  std::size_t head_cache_ = 0;                                   // producer's last view of head_
  alignas(kCacheLineBytes) std::atomic<std::size_t> head_{0};  // written by the consumer
  std::size_t tail_cache_ = 0;                                   // consumer's last view of tail_
};

}  // namespace clm::telemetry
