#!/usr/bin/env bash
# Process-level test of the loop's own deadline (labels unit, lcm;
# docs/servod.md "Faults", fault 210): clm-servod on config/servod.yaml (the
# embedded simulated motor, real-time clock, no real-time rights,
# faults.stall_limit_s 1 s for a loaded host) on an LCM port of its own. While
# a move runs, the daemon is stopped with SIGSTOP for 2 s and continued: on
# resume it latches fault 210 and reacts with a quick stop (the status shows
# the fault, no program running), whatever the simulated drive did meanwhile.
# About 10 s.
#
#   servod_stall_test.sh CLM_SERVOD CLM SOURCE_DIR WORK_DIR
set -euo pipefail
servod=$1 clm=$2 source_dir=$3 work=$4
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"

# A port of its own (10320..10359), apart from the other LCM tests.
port=$((10320 + $$ % 40))
url="udpm://239.255.76.67:${port}?ttl=0"
rm -rf "$work"
mkdir -p "$work"
trap "cleanup_processes || true" EXIT
fail() { fail_with_status "$*" "$work"/servod*.log; }

process_test_config "$work/servod.yaml" "  lock_memory: false"
start_daemon "$work/servod.yaml" "$work/servod.log"
pid=$servod_pid
rc=0
wait_for_status "$pid" 20 || rc=$?
[ $rc != 2 ] || fail "clm-servod exited at start-up"
[ $rc = 0 ] || fail "no status from clm-servod within 20 s"
reply=$(ctl enable) || fail "enable refused: $reply"
reply=$(ctl move-to --target-m 0.08 --velocity-m-per-s 0.02) || fail "move-to refused: $reply"
s=$(ctl status) || fail "no status after move-to"
[ "$(field program_running "$s")" = true ] || fail "no program running after move-to: $(field program_running "$s")"
kill -STOP "$pid"
sleep 2
kill -CONT "$pid"
# The fault on resume (bounded: the status comes at 10 Hz; 10 s for a loaded host).
start=$(date +%s)
until s=$(ctl status 2>/dev/null) && [ "$(field fault "$s")" = 210 ]; do
  [ $(( $(date +%s) - start )) -lt 10 ] || fail "no fault 210 within 10 s of SIGCONT after a 2 s SIGSTOP: fault $(field fault "$s") ($(field fault_reason "$s"))"
  sleep 0.1
done
[ "$(field state "$s")" = fault ] || fail "state after the stall: $(field state "$s"), expected fault"
# The quick stop of its reaction ends: no program runs (bounded, 10 s).
start=$(date +%s)
until s=$(ctl status 2>/dev/null) && [ "$(field program_running "$s")" = false ]; do
  [ $(( $(date +%s) - start )) -lt 10 ] || fail "a program still runs 10 s after fault 210"
  sleep 0.1
done
kill -0 "$pid" 2>/dev/null || fail "clm-servod died"
rc=0
stop_process "$pid" 50 || rc=$?
[ $rc = 0 ] || fail "clm-servod exit status $rc after SIGTERM, expected 0"
echo "stall: a 2 s SIGSTOP during a move latched fault 210 ($(field fault_reason "$s")) on resume; the quick stop ended; clean exit"
