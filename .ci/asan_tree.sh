# Sourced by .ci/sanitize.sh and .ci/fuzz.sh: configures build-asan/, the one
# instrumented tree of CI (docs/fuzzing.md). clang++-14 (it compiles this tree
# in about half of GCC's time), every target under AddressSanitizer,
# UndefinedBehaviorSanitizer with float-cast-overflow, and libFuzzer's
# coverage (CLM_FUZZ), so that the same tree holds the unit tests and the
# fuzz harnesses. -O1 -gline-tables-only as OSS-Fuzz builds: line numbers in
# every report; no -DNDEBUG, so assert() and Eigen's index checks are on.
# Only the test binaries of `ctest -L unit -LE lcm` (CLM_UNIT_TESTS_ONLY).
configure_asan_tree() {
  command -v clang++-14 > /dev/null || { echo "ci: no clang++-14: run bash .ci/install-deps.sh" >&2; return 1; }
  cmake -S . -B build-asan -DCMAKE_CXX_COMPILER=clang++-14 -DCMAKE_BUILD_TYPE=RelWithDebInfo \
        "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only" -DCLM_FUZZ=ON -DCLM_BUILD_BENCHMARKS=OFF \
        -DCLM_UNIT_TESTS_ONLY=ON >/dev/null
}
