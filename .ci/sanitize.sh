#!/usr/bin/env bash
# The unit tests under AddressSanitizer and UndefinedBehaviorSanitizer
# (docs/fuzzing.md): configures build-asan/ with CLM_SANITIZE=address;undefined
# (GCC; every target instrumented; any finding aborts), builds with -j2 and
# runs `ctest -L unit -LE lcm` (the tests labelled lcm need UDP multicast).
# Exits non-zero on a failed test or any sanitizer report.
#
# -O1 -g1: half the compile time of -O2 -g with line numbers in every report;
# no -DNDEBUG, so assert() and Eigen's index checks are on as well.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1" \
      "-DCLM_SANITIZE=address;undefined" -DCLM_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build build-asan -j2
cd build-asan
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1:check_initialization_order=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
ctest -L unit -LE lcm --output-on-failure -j2 --timeout 1800
