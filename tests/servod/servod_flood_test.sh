#!/usr/bin/env bash
# The command channel under flood (docs/servod.md "Command authority" and
# "Receiving commands", docs/reliability.md "Command channel under flood"):
# the daemon on the real-time clock at 1 kHz, on an LCM port of its own per
# mode; floods from tests/support/flood_lcm.py, which needs no LCM library.
#
#   servod_flood_test.sh MODE CLM_SERVOD CLM SOURCE_DIR WORK_DIR
#
# MODE stop       1200 datagrams/s of forged-id reads and unauthorised commands
#                 (1000 made-up clients, signed with the operators' key: the
#                 worst case, a flood from a holder of the key) while a program runs: clm ctl stop,
#                 quick-stop and disable are accepted from the operator's id and
#                 a new one, and 30 stop/quick stop/disable datagrams are acked
#                 with a median latency of at most 50 ms; no command is refused
#                 for lack of a client slot.
#      refused-stops  3 s of 500 stop/quick stop/disable datagrams/s for
#                 another axis: every one refused (other_axis), and the
#                 daemon's stderr has at most 5 "refused" lines a second, each
#                 with its time, kind, code and reason, and "N more ...
#                 suppressed" lines whose N with the lines logged add up to
#                 the refusals the status counts.
#      fragments  10 s of 200 datagrams/s of LCM fragments whose header claims
#                 2^28 - 1 bytes, with the memory locked (mlockall): the
#                 daemon's resident memory stays within 10 MB of its idle value
#                 and every fragment is counted in datagrams_dropped.
set -euo pipefail
mode=$1 servod=$2 clm=$3 source_dir=$4 work=$5
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"
flood="$source_dir/tests/support/flood_lcm.py"

# A port of its own per mode (10400..10479 and 10650..10689, no other test's).
case $mode in
  stop) base=10400 ;; fragments) base=10440 ;; refused-stops) base=10650 ;;
  *) echo "unknown mode $mode" >&2; exit 2 ;;
esac
port=$((base + $$ % 40))
url="udpm://239.255.76.67:${port}?ttl=0"
rm -rf "$work"
mkdir -p "$work"
trap "cleanup_processes || true" EXIT

fail() {
  echo "FAIL ($mode): $*" >&2
  for log in "$work"/*.log; do [ -f "$log" ] && { echo "--- $log:" >&2; tail -n 20 "$log" >&2; }; done
  exit 1
}


up() {  # CONFIG LOG
  start_daemon "$1" "$2"
  pid=$servod_pid
  local rc=0
  wait_for_status "$pid" 8 || rc=$?
  [ $rc = 0 ] || fail "clm-servod on $1 did not come up (wait_for_status $rc)"
}

# The count after NAME in the `commands:` line of STATUS.
commands() { field commands "$1" | sed -n "s/\(^\|.*[ ,]\)$2 \([0-9]*\).*/\2/p"; }
try_ctl() { set +e; reply=$(ctl "$@" 2>&1); rc=$?; set -e; }
rss_kb() { sed -n 's/^VmRSS:[[:space:]]*\([0-9]*\) kB/\1/p' "/proc/$1/status"; }

case $mode in
# ---------------------------------------------------------------------------------
stop)
  process_test_config "$work/servod.yaml" "  lock_memory: false"
  up "$work/servod.yaml" "$work/servod.log"
  session=$(field session "$(ctl status)")
  reply=$(ctl enable) || fail "enable: $reply"
  before=$(ctl status)
  python3 "$flood" flood "$url" --session "$session" --kind mixed --rate 1200 --duration-s 40 --sign \
      > "$work/flood.out" 2> "$work/flood.log" &
  flood_pid=$!
  pids+=("$flood_pid")
  # The flood reaches the daemon: its reads are admitted, its commands refused (bounded wait).
  ok=0
  for _ in $(seq 1 20); do
    s=$(ctl status 2>/dev/null) || continue
    reads=$(( $(commands "$s" admitted) - $(commands "$before" admitted) ))
    refused=$(( $(commands "$s" not_in_control) - $(commands "$before" not_in_control) ))
    [ "$reads" -gt 500 ] && [ "$refused" -gt 500 ] && { ok=1; break; }
    sleep 0.2
  done
  [ $ok = 1 ] || fail "the flood does not reach the daemon: admitted +$reads, not_in_control +$refused (bound: > 500 each)"
  # A program runs; the operator stops it, from its own id and from a new one.
  reply=$(ctl move-to --target-m 0.05 --velocity-m-per-s 0.01) || fail "move-to under the flood: $reply"
  for command in stop quick-stop disable; do
    try_ctl "$command"
    [ $rc = 0 ] && [ "$reply" = accepted ] || fail "clm ctl $command under the flood: exit $rc, '$reply'"
    try_ctl --client-id 4243 "$command"
    [ $rc = 0 ] && [ "$reply" = accepted ] || fail "clm ctl --client-id 4243 $command under the flood: exit $rc, '$reply'"
  done
  s=$(ctl status)
  [ "$(field state "$s")" = disabled ] || fail "state after disable under the flood: $(field state "$s")"
  [ "$(field program_running "$s")" = false ] || fail "a program still runs after stop and disable"
  # Ack latency: 30 datagrams, stop, quick stop and disable in turn.
  python3 "$flood" stop-latency "$url" --session "$session" --count 30 > "$work/latency.out" 2>&1 ||
      fail "stop-latency: a safety command was refused or unacked: $(grep -v accepted "$work/latency.out" | head -3)"
  median=$(sed -n 's/^median_ms \([0-9.]*\) .*/\1/p' "$work/latency.out")
  [ -n "$median" ] || fail "no median in $(cat "$work/latency.out")"
  [ "$(echo "$median <= 50" | bc)" = 1 ] || fail "median ack latency of stop under the flood $median ms (bound 50 ms)"
  kill -0 "$flood_pid" 2>/dev/null || fail "the flood ended before the measurement did: $(cat "$work/flood.out")"
  s=$(ctl status)
  [ "$(commands "$s" no_client)" = 0 ] || fail "commands refused no_client: $(commands "$s" no_client) (bound 0)"
  kill "$flood_pid" 2>/dev/null || true
  wait "$flood_pid" 2>/dev/null || true
  echo "under 1200 datagrams/s of forged reads and unauthorised commands: clm ctl stop, quick-stop, disable accepted" \
       "from two clients; $(tail -n 1 "$work/latency.out"); $(field commands "$s")"
  ;;
# ---------------------------------------------------------------------------------
refused-stops)
  process_test_config "$work/servod.yaml" "  lock_memory: false"
  up "$work/servod.yaml" "$work/servod.log"
  session=$(field session "$(ctl status)")
  before=$(ctl status)
  start=$(date +%s)
  python3 "$flood" flood "$url" --session "$session" --kind stops-other-axis --rate 500 --duration-s 3 \
      > "$work/flood.out" 2> "$work/flood.log" || fail "the flood failed: $(cat "$work/flood.log")"
  # Every refusal is counted by then (bounded wait); its second is over 1 s
  # after the last, and the monitor says the suppressed ones within a status period.
  sleep 2
  s=$(ctl status)
  refused=$(( $(commands "$s" other_axis) - $(commands "$before" other_axis) ))
  elapsed=$(( $(date +%s) - start + 1 ))
  [ "$refused" -gt 500 ] || fail "only $refused stops for another axis refused (the flood: $(cat "$work/flood.out"))"
  sent=$(sed -n 's/^flood stops-other-axis: \([0-9]*\) datagrams.*/\1/p' "$work/flood.out")
  verdict=$(py_check "$work/servod.log" "$refused" "$elapsed" "$sent" <<'CHECK'
import re, sys, collections
lines = open(sys.argv[1]).read().splitlines()
refused, elapsed, sent = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
logged = [l for l in lines if l.startswith("clm-servod: warning: refused ")]
pattern = re.compile(r"clm-servod: warning: refused (stop|quick_stop|disable) at "
                     r"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d)\.\d{3}Z from client \d+ \(sequence \d+\): "
                     r"code \d+, (other_axis: for axis 'other-axis', this daemon drives axis 'axis0'|command queue full .*)$")
per_second = collections.Counter()
for line in logged:
    m = pattern.match(line)
    assert m, f"a refusal line without time, kind, code and reason: {line}"
    per_second[m.group(2)] += 1
assert logged, "no refused safety command logged"
assert max(per_second.values()) <= 5, f"more than 5 refusals logged in one second: {per_second.most_common(1)}"
suppressed = sum(int(m.group(1)) for l in lines
                 for m in [re.match(r"clm-servod: warning: (\d+) more refusals of safety commands suppressed", l)] if m)
# Every refusal the status counts is logged or counted as suppressed; those
# refused before the command thread (its queue full: no status counter) come
# on top, and nothing beyond what was sent.
assert refused <= len(logged) + suppressed <= sent, \
    f"{len(logged)} logged + {suppressed} suppressed; the status counts {refused} refused, {sent} were sent"
print(f"{refused} refused stops for another axis: {len(logged)} lines logged (at most "
      f"{max(per_second.values())} a second) and {suppressed} counted in 'suppressed' lines")
CHECK
) || fail "the journal: $verdict"
  echo "$verdict"
  ;;
# ---------------------------------------------------------------------------------
fragments)
  process_test_config "$work/servod.yaml" "  lock_memory: true"
  up "$work/servod.yaml" "$work/servod.log"
  if grep -q "mlockall" "$work/servod.log"; then
    echo "SKIP: mlockall refused here ($(grep mlockall "$work/servod.log")): without locked memory the test cannot fail"
    exit 77
  fi
  sleep 1
  idle=0
  for _ in $(seq 1 5); do v=$(rss_kb "$pid"); [ "$v" -gt "$idle" ] && idle=$v; sleep 0.1; done
  before=$(ctl status)
  python3 "$flood" flood "$url" --kind fragments --rate 200 --duration-s 10 > "$work/flood.out" 2> "$work/flood.log" &
  flood_pid=$!
  pids+=("$flood_pid")
  peak=$idle
  while kill -0 "$flood_pid" 2>/dev/null; do
    v=$(rss_kb "$pid") || fail "clm-servod died during the fragment flood"
    [ "$v" -gt "$peak" ] && peak=$v
    sleep 0.2
  done
  wait "$flood_pid" || fail "the flood failed: $(cat "$work/flood.log")"
  sent=$(sed -n 's/^flood fragments: \([0-9]*\) datagrams.*/\1/p' "$work/flood.out")
  # The count reaches the sent number (bounded wait for the next status).
  ok=0
  for _ in $(seq 1 20); do
    s=$(ctl status)
    dropped=$(( $(commands "$s" datagrams_dropped) - $(commands "$before" datagrams_dropped) ))
    [ "$dropped" -ge "$sent" ] && { ok=1; break; }
    sleep 0.2
  done
  [ $ok = 1 ] || fail "datagrams_dropped grew by $dropped, $sent fragments were sent"
  v=$(rss_kb "$pid"); [ "$v" -gt "$peak" ] && peak=$v
  growth=$(( peak - idle ))
  [ "$growth" -le 10240 ] ||
      fail "resident memory grew from $idle kB to $peak kB under the fragment flood (+$growth kB, bound +10240 kB)"
  echo "fragment flood: $(cat "$work/flood.out"); RSS idle $idle kB, peak $peak kB (+$growth kB); datagrams_dropped +$dropped"
  ;;
esac
rc=0
stop_process "$pid" 30 || rc=$?
[ $rc = 0 ] || fail "clm-servod exit $rc after SIGTERM"
