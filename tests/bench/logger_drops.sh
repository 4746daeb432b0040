#!/usr/bin/env bash
# CLM_SERVO_STATE messages lost at the receiver by lcm-logger at 1 kHz,
# counted by `clm log2csv` from the gaps in the cycle counter
# (docs/telemetry.md, "Gaps"), for several ways of running lcm-logger side by
# side: the default URL, a larger UDP receive buffer (recv_buf_size=), the
# logger at the lowest CPU priority (nice 19, as on a busy host), and the
# logger SCHED_FIFO (chrt). clm-servod runs config/servod.yaml (the embedded
# simulated motor, real-time clock, state_decimation 1, no real-time rights)
# on an LCM port of its own, enabled and moving back and forth. All loggers
# record the same DURATION_S at once, so they see the same load; ROUNDS such
# rounds. For each logger also the kernel's drops at its socket (receive
# buffer full; /proc/net/udp), which tell a full socket buffer from a loss
# inside LCM.
#
#   tests/bench/logger_drops.sh [duration_s=10] [rounds=3] [hogs=0] [stall_ms=0] [recv_buf_size_bytes=4194304]
#
# HOGS busy loops (nice 0) load the CPUs meanwhile. With STALL_MS above 0
# every logger is also held stopped (SIGSTOP, SIGCONT) for STALL_MS every
# 2 s, as a long preemption or a slow disk would hold it. Needs
# build/bin/clm-servod, build/bin/clm, lcm-logger, chrt and the rights for
# SCHED_FIFO, and a multicast route (docs/telemetry.md, "Multicast set-up and
# tests"). With LOGS_DIR set, the logs and the warnings of clm log2csv are
# kept there.
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=../support/script_helpers.sh
source tests/support/script_helpers.sh
duration=${1:-10}
rounds=${2:-3}
hogs=${3:-0}
stall_ms=${4:-0}
buffer=${5:-4194304}
# shellcheck disable=SC2034  # read by script_helpers.sh
servod=build/bin/clm-servod clm=build/bin/clm source_dir=.
# A port of its own, away from the test scripts' 7700..9989.
port=$((7600 + $$ % 50))
url="udpm://239.255.76.67:${port}?ttl=0"
work=$(mktemp -d)
trap 'cleanup_processes; rm -rf "$work"' EXIT
fail() { fail_with_status "$*" "$work/servod.log"; }

# The loggers: a name, the command before lcm-logger (unquoted words; nice
# and chrt exec it, so $! is the logger), the URL options after ttl=0.
names=(default buffer nice19 nice19-buffer fifo-buffer)
prefixes=("" "" "nice -n 19" "nice -n 19" "chrt -f 10")
options=("" "&recv_buf_size=$buffer" "" "&recv_buf_size=$buffer" "&recv_buf_size=$buffer")

missing=$(loaded_host_motor config/motor-sim.yaml "$work/motor-sim.yaml" "${ABSOLUTE_MOTOR[@]}") ||
    fail "motor: no line '$missing' after editing"
missing=$(config_edit config/servod.yaml "$work/servod.yaml" "${ABSOLUTE_CONFIG[@]}" \
          "motor_file: $work/motor-sim.yaml" "  priority: 0" "  lock_memory: false" "  clock: realtime" \
          "  lcm_url: \"$url\"" "  overrun_limit: 1000") || fail "config: no line '$missing' after editing"
start_daemon "$work/servod.yaml" "$work/servod.log"
rc=0
# shellcheck disable=SC2154  # servod_pid: set by start_daemon
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
for _ in $(seq 1 "$hogs"); do
  (while true; do :; done) &
  pids+=("$!")
done

echo "load average $(cut -d' ' -f1-3 /proc/loadavg) (with $hogs busy loops); net.core.rmem_default" \
     "$(sysctl -n net.core.rmem_default), net.core.rmem_max $(sysctl -n net.core.rmem_max);" \
     "loggers stopped ${stall_ms} ms every 2 s"
# "STATES MISSING DROPPED" of a log: its states, those missing and the
# daemon's own drops, from clm log2csv's warning (none: 0).
count() {
  local warning states missing dropped
  warning=$("$clm" log2csv --log "$1" --output "$1.csv" --format full 2>&1 > /dev/null) ||
      { echo "log2csv failed: $warning" >&2; exit 1; }
  states=$(($(wc -l < "$1.csv") - 1))
  if [ -n "${LOGS_DIR:-}" ]; then
    mkdir -p "$LOGS_DIR"
    cp "$1" "$LOGS_DIR/"
    [ -z "$warning" ] || echo "$warning" > "$LOGS_DIR/$(basename "$1").warning"
  fi
  missing=$(sed -n 's/.*: \([0-9]*\) CLM_SERVO_STATE messages\{0,1\} missing.*/\1/p' <<< "$warning")
  dropped=$(sed -n 's/.*the daemon counted \([0-9]*\) telemetry.*/\1/p' <<< "$warning")
  echo "$states ${missing:-0} ${dropped:-0}"
}
# The kernel's count of datagrams dropped at the UDP sockets of process PID
# (receive buffer full), and their receive buffer sizes: /proc/net/udp by
# socket inode, and ss.
socket_drops() {
  local inodes
  inodes=$(find "/proc/$1/fd" -lname 'socket:*' -printf '%l\n' 2>/dev/null | sed 's/socket:\[\([0-9]*\)\]/\1/' |
           tr '\n' '|')
  awk -v inodes="|$inodes" 'NR > 1 && index(inodes, "|" $10 "|") { sum += $NF } END { print sum + 0 }' \
      /proc/net/udp
}
receive_buffer() {
  ss -uampnH 2>/dev/null | grep -A1 ":$port .*pid=$1," | sed -n 's/.*skmem:(r[0-9]*,rb\([0-9]*\),.*/\1/p' |
      head -n 1
}

declare -A states_sum missing_sum kernel_sum
for round in $(seq 1 "$rounds"); do
  loggers=()
  for i in "${!names[@]}"; do
    # shellcheck disable=SC2086
    ${prefixes[$i]} lcm-logger -q --lcm-url="$url${options[$i]}" "$work/${names[$i]}-$round.lcm" \
        2> "$work/logger-${names[$i]}.log" &
    loggers+=("$!")
    pids+=("$!")
  done
  sleep 0.5
  if [ "$stall_ms" -gt 0 ]; then
    stall=$(awk -v ms="$stall_ms" 'BEGIN { printf "%.3f", ms / 1000 }')
    end=$((SECONDS + duration))
    while [ $SECONDS -lt $end ]; do
      sleep 2
      kill -STOP "${loggers[@]}"
      sleep "$stall"
      kill -CONT "${loggers[@]}"
    done
  else
    sleep "$duration"
  fi
  echo "round $round:"
  for i in "${!names[@]}"; do
    kernel[i]=$(socket_drops "${loggers[$i]}")
    rb[i]=$(receive_buffer "${loggers[$i]}")
  done
  kill -INT "${loggers[@]}"
  for pid in "${loggers[@]}"; do wait "$pid" || true; done
  for i in "${!names[@]}"; do
    read -r states missing dropped < <(count "$work/${names[$i]}-$round.lcm")
    printf '  %-13s %-12s lcm-logger --lcm-url=%s: %6d states, %4d missing (%5.2f %%), kernel socket drops %4d' \
           "${names[$i]}" "${prefixes[$i]:--}" "'$url${options[$i]}'" "$states" "$missing" \
           "$(awk -v m="$missing" -v s="$states" 'BEGIN { print 100 * m / (m + s) }')" "${kernel[$i]}"
    echo " (rb ${rb[$i]:-?} bytes), the daemon dropped $dropped"
    states_sum[$i]=$(( ${states_sum[$i]:-0} + states ))
    missing_sum[$i]=$(( ${missing_sum[$i]:-0} + missing ))
    kernel_sum[$i]=$(( ${kernel_sum[$i]:-0} + kernel[i] ))
  done
done
echo "all rounds:"
for i in "${!names[@]}"; do
  percent=$(awk -v m="${missing_sum[$i]}" -v s="${states_sum[$i]}" 'BEGIN { print 100 * m / (m + s) }')
  printf '  %-13s %7d states, %5d missing (%5.2f %%), kernel socket drops %5d\n' "${names[$i]}" "${states_sum[$i]}" \
         "${missing_sum[$i]}" "$percent" "${kernel_sum[$i]}"
done
status=$(ctl status) || fail "no status at the end"
echo "daemon: $(field state "$status"), fault $(field fault "$status"); $(grep -E '^telemetry' <<< "$status" || true)"
