#!/usr/bin/env bash
# Configures and builds clm-servo into build/ (Release, warnings as errors):
# everything (tests and benchmarks included), or with `main` only `clm`, the
# program the main job runs (.ci/main). The same tree serves both: a later
# full build reuses what `main` compiled.
#
#   bash .ci/build.sh        # everything (.ci/run)
#   bash .ci/build.sh main   # clm alone
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-all}" in
  main)
    cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCLM_WERROR=ON -DCLM_BUILD_TESTS=OFF -DCLM_BUILD_BENCHMARKS=OFF >/dev/null
    cmake --build build -j2 --target clm
    ;;
  all)
    cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCLM_WERROR=ON -DCLM_BUILD_TESTS=ON -DCLM_BUILD_BENCHMARKS=ON >/dev/null
    cmake --build build -j2
    ;;
  *) echo "usage: build.sh [main]" >&2; exit 2 ;;
esac
