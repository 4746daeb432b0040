#!/usr/bin/env bash
# Process-level test of stops at speed through `clm ctl` against clm-servod
# (labels unit and lcm): the daemon on config/servod.yaml (the simulated
# motor, real-time clock at 1 kHz, no real-time rights) on an LCM port of its
# own. A move-to beyond the motion limits is refused with the reason; a move at
# 0.3 m/s stopped by `clm ctl stop` and one stopped by `clm ctl quick-stop`
# come to rest without a fault, enabled, the move no longer running; a move
# to the other end afterwards completes. About 4 s.
#
#   servod_stop_test.sh CLM_SERVOD CLM SOURCE_DIR WORK_DIR
set -euo pipefail
servod=$1 clm=$2 source_dir=$3 work=$4
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"

# A port of its own (servod_process_test.sh uses 9800..9949; LCM tests 7700..9699).
port=$((9950 + $$ % 40))
url="udpm://239.255.76.67:${port}?ttl=0"
rm -rf "$work"
mkdir -p "$work"
trap cleanup_processes EXIT

fail() {
  echo "FAIL: $*" >&2
  echo "--- clm-servod stderr:" >&2
  cat "$work/servod.log" >&2 || true
  exit 1
}

# The simulated drive's watchdog at 0.1 s instead of 5 ms: without real-time
# rights on a shared machine a wake-up can come several periods late, and this
# test is about stops, not about the loop's timing (servod_process_test.sh
# and the HIL suite keep the 5 ms).
missing=$(config_edit "$source_dir/config/motor-sim.yaml" "$work/motor-sim.yaml" "  watchdog_timeout_s: 0.1") ||
    fail "motor: no line '$missing' after editing"
missing=$(config_edit "$source_dir/config/servod.yaml" "$work/servod.yaml" \
          "motor_file: $work/motor-sim.yaml" "  priority: 0" "  lock_memory: false" "  clock: realtime" \
          "  lcm_url: \"$url\"" && config_require "$work/servod.yaml" "  velocity_m_per_s: 0.5") ||
    fail "config: no line '$missing' after editing"

start_daemon "$work/servod.yaml" "$work/servod.log"
pid=$servod_pid
rc=0
wait_for_status $pid 5 || rc=$?
[ $rc != 2 ] || fail "clm-servod exited at start-up"
[ $rc = 0 ] || fail "clm ctl status saw no CLM_SERVO_STATUS within 5 s"
reply=$(ctl enable) || fail "enable refused: $reply"

# Beyond the motion limits: refused with the value and the limit.
set +e
reply=$(ctl move-to --target-m 0.05 --velocity-m-per-s 1000000)
rc=$?
set -e
[ $rc = 1 ] || fail "move-to at 1e6 m/s: exit status $rc, expected 1"
[[ "$reply" == *"velocity_m_per_s 1e+06 m/s exceeds the limit 0.5 m/s"* ]] || fail "move-to at 1e6 m/s: '$reply'"

# Waits until the move has ended (program_running false), at most 3 s; no fault meanwhile.
wait_idle() {
  for _ in $(seq 1 60); do
    status=$(ctl status) || fail "no status"
    [ "$(field fault "$status")" = 0 ] || fail "$1: fault $(field fault "$status") ($(field fault_reason "$status"))"
    [ "$(field state "$status")" = enabled ] || fail "$1: state $(field state "$status")"
    [ "$(field program_running "$status")" = false ] && return 0
    sleep 0.05
  done
  fail "$1: still running after 3 s"
}

ctl move-to --target-m -0.1 --velocity-m-per-s 0.3 --acceleration-m-per-s2 10 > /dev/null || fail "move-to -0.1 refused"
wait_idle "to the start"
for kind in stop quick-stop; do
  # 0.2 m at 0.3 m/s takes 0.7 s; the stop follows the move's ack at once.
  reply=$(ctl move-to --target-m 0.1 --velocity-m-per-s 0.3 --acceleration-m-per-s2 10) || fail "$kind: move-to refused: $reply"
  reply=$(ctl "$kind") || fail "$kind refused: $reply"
  [ "$reply" = accepted ] || fail "$kind: '$reply'"
  sleep 0.15
  # Stopped well before the move would have ended, at rest, no fault.
  status=$(ctl status) || fail "$kind: no status"
  [ "$(field program_running "$status")" = false ] || fail "$kind: the move still runs 0.15 s after the stop"
  [ "$(field fault "$status")" = 0 ] || fail "$kind: fault $(field fault "$status") ($(field fault_reason "$status"))"
  [ "$(field state "$status")" = enabled ] || fail "$kind: state $(field state "$status")"
  sleep 0.3
  status=$(ctl status) || fail "$kind: no status"
  [ "$(field fault "$status")" = 0 ] || fail "$kind: fault $(field fault "$status") after the stop"
  ctl move-to --target-m -0.1 --velocity-m-per-s 0.3 --acceleration-m-per-s2 10 > /dev/null ||
      fail "$kind: move-to back refused"
  wait_idle "$kind: back to the start"
done

rc=0
stop_process $pid 20 || rc=$?
trap - EXIT
[ $rc = 0 ] || fail "clm-servod exit status $rc after SIGTERM, expected 0"
echo "clm-servod stop test: refusal beyond the limits, stop and quick stop at 0.3 m/s without a fault"
