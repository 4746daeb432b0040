#!/usr/bin/env bash
# The unit tests under AddressSanitizer and UndefinedBehaviorSanitizer
# (docs/fuzzing.md): configures build-asan/ (.ci/asan_tree.sh: clang++-14,
# every target instrumented, any finding aborts), builds it with -j2 (the
# fuzz harnesses of .ci/fuzz.sh included) and runs `ctest -L unit -LE lcm`
# (the tests labelled lcm need UDP multicast). Exits non-zero on a failed
# test or any sanitizer report.
set -euo pipefail
cd "$(dirname "$0")/.."
source .ci/asan_tree.sh
configure_asan_tree
cmake --build build-asan -j2
cd build-asan
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1:check_initialization_order=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
ctest -L unit -LE lcm --output-on-failure -j2 --timeout 1800
