#pragma once
// Hands an object built off the real-time thread (a move program, a
// commutation law) to the cycle without locks, and tells the owner when it
// may be freed. The owner keeps every object it posted; the cycle only
// borrows pointers.
//
// Ordering: the cycle publishes an adopted pointer as `current` BEFORE it
// clears `pending`, and the owner reads `pending` BEFORE `current`, so an
// object is always visible in one of the two while the cycle may use it.

#include <atomic>

namespace clm::servo {

template <typename T>
class Handover {
 public:
  /// Owner: offers `object` to the cycle. False if an earlier offer is still pending.
  bool post(const T* object) noexcept {
    const T* expected = nullptr;
    return pending_.compare_exchange_strong(expected, object, std::memory_order_acq_rel);
  }

  /// Cycle: the offered object if there is one (and makes it current), else nullptr.
  const T* adopt() noexcept {
    const T* offered = pending_.load(std::memory_order_acquire);
    if (offered == nullptr) return nullptr;
    current_.store(offered, std::memory_order_release);
    pending_.store(nullptr, std::memory_order_release);
    return offered;
  }

  /// Cycle: sets the current object directly (e.g. nullptr when a program ends).
  void set_current(const T* object) noexcept { current_.store(object, std::memory_order_release); }

  /// Owner: true while the cycle may still use `object`.
  bool in_use(const T* object) const noexcept {
    if (pending_.load(std::memory_order_acquire) == object) return true;
    return current_.load(std::memory_order_acquire) == object;
  }

  bool pending() const noexcept { return pending_.load(std::memory_order_acquire) != nullptr; }

  /// Owner: true when `object` is the one the cycle uses now (not merely offered).
  bool is_current(const T* object) const noexcept { return current_.load(std::memory_order_acquire) == object; }

 private:
  std::atomic<const T*> pending_{nullptr};
  std::atomic<const T*> current_{nullptr};
};

}  // namespace clm::servo
