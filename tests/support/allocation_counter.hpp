#pragma once
// Counts heap allocations made by the current thread while a scope is open.
// Linking allocation_counter.cpp replaces the global operator new/delete.

#include <cstddef>

namespace clm::test {

/// Allocations (operator new / malloc-family via new) by this thread since construction.
class AllocationScope {
 public:
  AllocationScope();
  ~AllocationScope();
  AllocationScope(const AllocationScope&) = delete;
  AllocationScope& operator=(const AllocationScope&) = delete;
  std::size_t allocations() const;

 private:
  std::size_t start_;
};

}  // namespace clm::test
