#pragma once
// Counts calls of the C heap functions (malloc, calloc, realloc,
// aligned_alloc, posix_memalign) by this thread from code linked statically
// into the test binary: the project's libraries and the Eigen code compiled
// into them. Eigen allocates its dynamic matrices with std::malloc, which
// the operator-new counter (support/allocation_counter.hpp) does not see.
// Needs the linker's --wrap for each function (tests/daemon/CMakeLists.txt).

#include <cstddef>

namespace clm::test {

/// Heap calls made by this thread since the program started.
std::size_t malloc_calls() noexcept;

}  // namespace clm::test
