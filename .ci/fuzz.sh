#!/usr/bin/env bash
# Builds the libFuzzer harnesses of tests/fuzz (docs/fuzzing.md) in
# build-asan/ (.ci/asan_tree.sh; after .ci/sanitize.sh they are built
# already) and runs each for FUZZ_SECONDS (default 10) seconds on its seed
# corpus: 8 harnesses, two at a time (80 s of fuzzing in about 40 s). Exits
# non-zero if any harness finds a crash, a sanitizer report, a leak, a
# timeout or a broken invariant; the input is kept in build-asan/artifacts/.
#
#   FUZZ_SECONDS=60 bash .ci/fuzz.sh   # longer runs of every harness
#   FUZZ_SEED=0 bash .ci/fuzz.sh       # a fresh random seed (default: fixed, 1)
#   FUZZ_ONLY=fuzz_model_file bash .ci/fuzz.sh   # one harness
set -euo pipefail
cd "$(dirname "$0")/.."

source .ci/asan_tree.sh
configure_asan_tree
cmake --build build-asan -j2 --target fuzzers

seconds="${FUZZ_SECONDS:-10}"
seed="${FUZZ_SEED:-1}"
fuzz_dir=tests/fuzz
out=build-asan/fuzz-run
rm -rf "$out"
mkdir -p "$out" build-asan/artifacts
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:symbolize=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

failed=()
ran=0
# run NAME DICT MAX_LEN SEED_FILES...: a fresh working corpus of the seeds
# and of tests/fuzz/regressions/NAME/, then NAME for $seconds, in the
# background, two harnesses at a time (one per core); report NAME prints the
# outcome once it has ended.
names=()
run() {
  local name=$1 dict=$2 max_len=$3
  shift 3
  if [ -n "${FUZZ_ONLY:-}" ] && [ "$name" != "$FUZZ_ONLY" ]; then return; fi
  local corpus="$out/corpus/$name"
  mkdir -p "$corpus"
  cp "$@" "$corpus/"
  # The inputs of fixed findings seed the run too.
  if [ -d "$fuzz_dir/regressions/$name" ]; then cp "$fuzz_dir/regressions/$name"/* "$corpus/"; fi
  local options=(-max_total_time="$seconds" -seed="$seed" -timeout=10 -rss_limit_mb=2048 -max_len="$max_len"
                 -print_final_stats=1 -artifact_prefix="build-asan/artifacts/$name-")
  if [ -n "$dict" ]; then options+=(-dict="$fuzz_dir/$dict"); fi
  while [ "$(jobs -rp | wc -l)" -ge 2 ]; do wait -n || true; done
  echo "fuzz: $name for ${seconds} s"
  names+=("$name")
  ( ./build-asan/tests/fuzz/"$name" "${options[@]}" "$corpus" >"$out/$name.log" 2>&1
    echo $? >"$out/$name.status" ) &
}

report() {
  local name=$1
  ran=$((ran + 1))
  if [ "$(cat "$out/$name.status" 2>/dev/null)" = 0 ]; then
    echo -n "fuzz: $name:"
    { grep -E "^stat::number_of_executed_units|^stat::new_units_added" "$out/$name.log" || true; } |
      tr -s ' \n' ' ' | sed 's/^/ /'
    echo
  else
    echo "fuzz: $name FAILED; log $out/$name.log, input in build-asan/artifacts/$name-*"
    grep -E -A25 "^==[0-9]+==ERROR|runtime error|fuzz invariant broken|terminate called|ERROR: libFuzzer" \
      "$out/$name.log" | head -60 || true
    failed+=("$name")
  fi
}

run fuzz_can_frames "" 32 "$fuzz_dir"/corpus/can_frames/*
run fuzz_servod_config yaml.dict 8192 config/servod*.yaml "$fuzz_dir"/corpus/servod_config/*
run fuzz_model_file yaml.dict 8192 "$fuzz_dir"/corpus/model_file/*
run fuzz_calibration_file yaml.dict 4096 "$fuzz_dir"/corpus/calibration_file/*
run fuzz_motor_file yaml.dict 8192 config/motor-sim*.yaml
run fuzz_csv_table csv.dict 4096 "$fuzz_dir"/corpus/experiment_data/*
run fuzz_experiment_data csv.dict 4096 "$fuzz_dir"/corpus/experiment_data/*
run fuzz_lcm_datagram "" 4096 "$fuzz_dir"/corpus/lcm_datagram/*
wait
for name in "${names[@]}"; do report "$name"; done

if [ "${#failed[@]}" -gt 0 ]; then
  echo "fuzz: ${#failed[@]} harnesses failed: ${failed[*]}"
  exit 1
fi
echo "fuzz: ${ran} harnesses, ${seconds} s each, no findings"
