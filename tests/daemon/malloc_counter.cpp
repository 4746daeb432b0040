#include "tests/daemon/malloc_counter.hpp"

#include <cstddef>

namespace {
thread_local std::size_t g_malloc_calls = 0;
}

namespace clm::test {
std::size_t malloc_calls() noexcept { return g_malloc_calls; }
}  // namespace clm::test

// The linker sends every call of `name` from the statically linked objects to
// __wrap_name; __real_name is the C library's.
extern "C" {
void* __real_malloc(std::size_t size);
void* __real_calloc(std::size_t count, std::size_t size);
void* __real_realloc(void* pointer, std::size_t size);
void* __real_aligned_alloc(std::size_t alignment, std::size_t size);
int __real_posix_memalign(void** pointer, std::size_t alignment, std::size_t size);

void* __wrap_malloc(std::size_t size) {
  ++g_malloc_calls;
  return __real_malloc(size);
}
void* __wrap_calloc(std::size_t count, std::size_t size) {
  ++g_malloc_calls;
  return __real_calloc(count, size);
}
void* __wrap_realloc(void* pointer, std::size_t size) {
  ++g_malloc_calls;
  return __real_realloc(pointer, size);
}
void* __wrap_aligned_alloc(std::size_t alignment, std::size_t size) {
  ++g_malloc_calls;
  return __real_aligned_alloc(alignment, size);
}
int __wrap_posix_memalign(void** pointer, std::size_t alignment, std::size_t size) {
  ++g_malloc_calls;
  return __real_posix_memalign(pointer, alignment, size);
}
}
