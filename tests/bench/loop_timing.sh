#!/usr/bin/env bash
# Loop timing of clm-servod next to cyclictest (Debian rt-tests), in the same
# run, at the same SCHED_FIFO priority: wake-up latency percentiles of both,
# their ratio, and the daemon's missed deadlines. Both run at once, so they
# see the same machine load.
#
#   tests/bench/loop_timing.sh [duration_s=60] [priority=80]
#
# Needs build/bin/clm-servod, cyclictest and root (SCHED_FIFO, mlockall).
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=../support/script_helpers.sh
source tests/support/script_helpers.sh
duration=${1:-60}
priority=${2:-80}
python=/usr/bin/python3
command -v cyclictest >/dev/null || { echo "loop_timing: cyclictest missing (apt-get install rt-tests)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

percentiles() {  # cyclictest histogram (one line per microsecond) -> p50 p99 p99.9 max [us]
  "$python" - "$1" <<'PY'
import sys
counts = []
maximum = None
for line in open(sys.argv[1]):
    if line.startswith("# Max Latencies:"):
        maximum = int(line.split()[-1])
    if line.startswith("#") or not line.strip():
        continue
    fields = line.split()
    counts.append((int(fields[0]), int(fields[1])))
total = sum(c for _, c in counts)
def q(p):
    target, seen = p * total, 0
    for value, c in counts:
        seen += c
        if seen >= target:
            return value
    return counts[-1][0]
print(q(0.5), q(0.99), q(0.999), maximum)
PY
}

echo "| rate | who | p50 [µs] | p99 [µs] | p99.9 [µs] | max [µs] | missed deadlines |"
echo "|---|---|---|---|---|---|---|"
for rate in 1000 4000; do
  interval_us=$((1000000 / rate))
  missing=$(config_edit config/servod.yaml "$work/servod-$rate.yaml" "motor_file: $PWD/config/motor-sim.yaml" \
            "  rate_hz: $rate" "  priority: $priority" "  enabled: false") ||
    { echo "loop_timing: config: no line '$missing' after editing" >&2; exit 2; }
  ./build/bin/clm-servod --config "$work/servod-$rate.yaml" --duration-s "$duration" 2> "$work/servod-$rate.log" &
  daemon=$!
  cyclictest -m -q -t 1 -p "$priority" --policy=fifo -i "$interval_us" -D "$duration" -h 20000 > "$work/cyclictest-$rate.txt"
  wait "$daemon"
  read -r c50 c99 c999 cmax < <(percentiles "$work/cyclictest-$rate.txt")
  line=$(grep "clm-servod: timing:" "$work/servod-$rate.log")
  d50=$(sed -E 's/.*latency p50 ([0-9.]+) us.*/\1/' <<<"$line")
  d99=$(sed -E 's/.*latency p50 [0-9.]+ us p99 ([0-9.]+) us.*/\1/' <<<"$line")
  d999=$(sed -E 's/.*p99.9 ([0-9.]+) us.*/\1/' <<<"$line")
  dmax=$(sed -E 's/.*p99.9 [0-9.]+ us max ([0-9.]+) us.*/\1/' <<<"$line")
  missed=$(sed -E 's/.*missed deadlines ([0-9]+).*/\1/' <<<"$line")
  echo "| $rate Hz | cyclictest | $c50 | $c99 | $c999 | $cmax | – |"
  echo "| $rate Hz | clm-servod | $d50 | $d99 | $d999 | $dmax | $missed |"
  "$python" -c "print('| $rate Hz | ratio daemon/cyclictest | %.2f | %.2f | %.2f | %.2f | |' % ($d50/max($c50,1), $d99/max($c99,1), $d999/max($c999,1), $dmax/max($cmax,1)))"
done
