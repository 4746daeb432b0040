#pragma once
// Shared by the libFuzzer harnesses (docs/fuzzing.md). A harness feeds its
// input to one reader; a documented refusal (the exception type the reader's
// header promises) ends the run quietly, anything else is a finding: a crash,
// a sanitizer report, an exception of another type (uncaught: libFuzzer
// reports the abort of std::terminate) or a broken invariant (fuzz::require).

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace clm::fuzz {

/// The input as text, NUL bytes included.
inline std::string as_text(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

/// Aborts with `what` when `condition` is false: libFuzzer saves the input
/// as a crash.
inline void require(bool condition, const char* what, const std::string& detail = std::string()) {
  if (condition) return;
  std::fprintf(stderr, "fuzz invariant broken: %s\n%s\n", what, detail.c_str());
  std::abort();
}

/// The source tree (CMake passes it), for the fixed files a harness reads.
inline std::string source_path(const char* relative) { return std::string(CLM_SOURCE_DIR) + "/" + relative; }

}  // namespace clm::fuzz
