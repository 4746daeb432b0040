#!/usr/bin/env bash
# CLM_SERVO_STATE messages lost at the receiver by lcm-logger at 1 kHz, with
# the kernel's default UDP receive buffer and with a larger one asked for in
# the LCM URL (recv_buf_size=), counted by `clm log2csv` from the gaps in the
# cycle counter (docs/telemetry.md, "Gaps"). clm-servod runs config/servod.yaml
# (the embedded simulated motor, real-time clock, state_decimation 1, no
# real-time rights) on an LCM port of its own, enabled and moving back and
# forth; both loggers record the same DURATION_S at once, so they see the
# same load. ROUNDS such rounds.
#
#   tests/bench/logger_drops.sh [duration_s=10] [recv_buf_size_bytes=4194304] [rounds=3]
#
# Needs build/bin/clm-servod, build/bin/clm, lcm-logger and a multicast route
# (docs/telemetry.md, "Multicast set-up and tests").
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=../support/script_helpers.sh
source tests/support/script_helpers.sh
duration=${1:-10}
buffer=${2:-4194304}
rounds=${3:-3}
servod=build/bin/clm-servod clm=build/bin/clm source_dir=.
# A port of its own, away from the test scripts' 7700..9989.
port=$((7600 + $$ % 50))
url="udpm://239.255.76.67:${port}?ttl=0"
work=$(mktemp -d)
trap 'cleanup_processes; rm -rf "$work"' EXIT
fail() { fail_with_status "$*" "$work/servod.log"; }

missing=$(config_edit config/motor-sim.yaml "$work/motor-sim.yaml" "  watchdog_timeout_s: 0.1") ||
    fail "motor: no line '$missing' after editing"
missing=$(config_edit config/servod.yaml "$work/servod.yaml" \
          "motor_file: $work/motor-sim.yaml" "  priority: 0" "  lock_memory: false" "  clock: realtime" \
          "  lcm_url: \"$url\"" "  overrun_limit: 1000") || fail "config: no line '$missing' after editing"
start_daemon "$work/servod.yaml" "$work/servod.log"
rc=0
wait_for_status "$servod_pid" 5 || rc=$?
[ $rc = 0 ] || fail "clm-servod gave no status (wait_for_status $rc)"
reply=$(ctl enable) || fail "enable refused: $reply"

# Moves back and forth for the whole time, so that the states change.
(
  while true; do
    ctl move-to --target-m 0.05 > /dev/null 2>&1 || true
    sleep 0.5
    ctl move-to --target-m -0.05 > /dev/null 2>&1 || true
    sleep 0.5
  done
) &
pids+=("$!")

echo "load average: $(cut -d' ' -f1-3 /proc/loadavg); net.core.rmem_default $(sysctl -n net.core.rmem_default)," \
     "net.core.rmem_max $(sysctl -n net.core.rmem_max)"
# The missing states and the daemon's drops from clm log2csv's warning (none: 0).
count() {
  local warning
  warning=$("$clm" log2csv --log "$1" --output "$1.csv" --format full 2>&1 > /dev/null) ||
      { echo "log2csv failed: $warning" >&2; exit 1; }
  local states missing dropped
  states=$(($(wc -l < "$1.csv") - 1))
  missing=$(sed -n 's/.*: \([0-9]*\) CLM_SERVO_STATE messages\{0,1\} missing.*/\1/p' <<< "$warning")
  dropped=$(sed -n 's/.*the daemon counted \([0-9]*\) telemetry.*/\1/p' <<< "$warning")
  echo "$states states, ${missing:-0} missing at the receiver ($(awk -v m="${missing:-0}" -v s="$states" \
       'BEGIN { printf "%.2f", 100 * m / (m + s) }') %), the daemon dropped ${dropped:-0}"
}
for round in $(seq 1 "$rounds"); do
  lcm-logger -q --lcm-url="$url" "$work/default-$round.lcm" 2> "$work/logger-default.log" &
  default_logger=$!
  lcm-logger -q --lcm-url="$url&recv_buf_size=$buffer" "$work/large-$round.lcm" 2> "$work/logger-large.log" &
  large_logger=$!
  pids+=("$default_logger" "$large_logger")
  sleep 0.5
  # The receive buffers the kernel gave the two loggers' sockets (ss: skmem rb).
  buffers=$(ss -uampn 2>/dev/null | grep -A1 "239.255.76.67:${port}\|0.0.0.0:${port}" |
            sed -n 's/.*skmem:(r[0-9]*,rb\([0-9]*\),.*/\1/p' | sort -n | uniq | tr '\n' ' ' || true)
  sleep "$duration"
  kill -INT "$default_logger" "$large_logger"
  wait "$default_logger" || true
  wait "$large_logger" || true
  echo "round $round: kernel receive buffers (rb) of the sockets on port $port: ${buffers:-unknown}"
  echo "  lcm-logger --lcm-url='$url':                       $(count "$work/default-$round.lcm")"
  echo "  lcm-logger --lcm-url='$url&recv_buf_size=$buffer': $(count "$work/large-$round.lcm")"
done
status=$(ctl status) || fail "no status at the end"
echo "daemon: $(field state "$status"), fault $(field fault "$status"); $(grep -E '^telemetry' <<< "$status" || true)"
