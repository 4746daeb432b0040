#!/usr/bin/env bash
# Process-level test of clm-servod and `clm ctl` over LCM (label unit): the
# daemon on the real-time clock at 1 kHz without real-time rights (priority 0,
# no mlockall), on an LCM port of its own: start-up refusals (exit 2), then
# status, enable, a short program, a refused command, SIGTERM and a clean
# exit 0 within 2 s; the systemd notifications it sent meanwhile. About 2 s.
#
#   servod_process_test.sh CLM_SERVOD CLM SOURCE_DIR WORK_DIR
set -euo pipefail
servod=$1 clm=$2 source_dir=$3 work=$4
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"

# A port of its own (the LCM tests use 7700..9699), so parallel runs and a
# daemon on the default port 7667 do not hear each other.
port=$((9800 + $$ % 150))
url="udpm://239.255.76.67:${port}?ttl=0"
rm -rf "$work"
mkdir -p "$work"

fail() {
  echo "FAIL: $*" >&2
  echo "--- clm-servod stderr:" >&2
  cat "$work/servod.log" >&2 || true
  exit 1
}

# config/servod.yaml with an absolute motor file, no real-time rights, our port.
missing=$(loaded_host_motor "$source_dir/config/motor-sim.yaml" "$work/motor-sim.yaml" "${ABSOLUTE_MOTOR[@]}" &&
          config_edit "$source_dir/config/servod.yaml" "$work/servod.yaml" "${ABSOLUTE_CONFIG[@]}" \
          "motor_file: $work/motor-sim.yaml" "  priority: 0" "  lock_memory: false" "  clock: realtime" \
          "  lcm_url: \"$url\"" "  overrun_limit: 1000" && config_require "$work/servod.yaml" "  rate_hz: 1000") ||
    fail "config: no line '$missing' after editing"

# 0.01 m out and back at 0.05 m/s: about 1 s.
cat > "$work/short-program.yaml" <<'PROGRAM'
format: clm-servo-program
format_version: 1
description: "process test: a short move out and back"
start_m: 0.0
steps:
  - {target_m: 0.01, velocity_m_per_s: 0.05, acceleration_m_per_s2: 1.0, jerk_m_per_s3: 1000.0, dwell_s: 0.1}
  - {target_m: 0.0, velocity_m_per_s: 0.05, acceleration_m_per_s2: 1.0, jerk_m_per_s3: 1000.0, dwell_s: 0.1}
PROGRAM

# 0. Start-up refusals: exit 2 with one line naming the cause.
expect_refusal() {  # CONFIG EXPECTED-LINE
  set +e
  "$servod" --config "$1" --duration-s 1 2> "$work/refusal.log"
  local rc=$?
  set -e
  [ $rc = 2 ] || fail "--config $1: exit status $rc, expected 2"
  [ "$(wc -l < "$work/refusal.log")" = 1 ] || fail "--config $1: not one line on stderr: $(cat "$work/refusal.log")"
  grep -qF -- "$2" "$work/refusal.log" || fail "--config $1: '$(cat "$work/refusal.log")' does not say '$2'"
}
expect_refusal "$work/no-such-config.yaml" "clm-servod: error: $work/no-such-config.yaml"
missing=$(config_edit "$work/servod.yaml" "$work/servod-require-realtime.yaml" "  cpu: 1023" "  require_realtime: true") ||
    fail "config: no line '$missing' after editing"
expect_refusal "$work/servod-require-realtime.yaml" \
    "clm-servod: error: pinning the loop thread to CPU 1023 failed: Invalid argument (loop.require_realtime is true)"

# Plays systemd: collects the notifications (READY, WATCHDOG, STATUS,
# STOPPING) on a unix datagram socket until STOPPING=1 or 20 s of silence (a
# loaded host may start the daemon slowly; STOPPING=1 ends it at once).
notify_dir=$(mktemp -d)
python3 - "$notify_dir/notify.sock" > "$work/notify.log" <<'LISTENER' &
import socket, sys
s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
s.bind(sys.argv[1])
s.settimeout(20.0)
try:
    while True:
        message = s.recv(4096).decode()
        print(message.replace("\n", "|"), flush=True)
        if "STOPPING=1" in message:
            break
except socket.timeout:
    pass
LISTENER
listener=$!
for _ in $(seq 1 50); do [ -S "$notify_dir/notify.sock" ] && break; sleep 0.02; done
[ -S "$notify_dir/notify.sock" ] || fail "the notify listener did not bind its socket"

NOTIFY_SOCKET="$notify_dir/notify.sock" WATCHDOG_USEC=200000 start_daemon "$work/servod.yaml" "$work/servod.log"
pid=$servod_pid
trap 'kill -KILL $pid $listener 2>/dev/null || true; rm -rf "$notify_dir"' EXIT

# 1. The daemon is up: a status arrives (the first within 20 s).
rc=0
wait_for_status $pid 20 || rc=$?
[ $rc != 2 ] || fail "clm-servod exited at start-up"
[ $rc = 0 ] || fail "clm ctl status saw no CLM_SERVO_STATUS within 20 s"
[ "$(field state "$status")" = disabled ] || fail "state after start: $(field state "$status")"
[ "$(field fault "$status")" = 0 ] || fail "fault after start: $(field fault "$status")"

# 2. enable, and the program.
reply=$(ctl enable) || fail "enable refused: $reply"
[ "$reply" = accepted ] || fail "enable: '$reply'"
reply=$(ctl run-program "$work/short-program.yaml") || fail "run-program refused: $reply"
[ "$reply" = "program posted" ] || fail "run-program: '$reply'"

# 3. It runs and ends (about 1 s; at most 20 s), without a fault.
saw_running=0 ended=0 program_start=$(date +%s)
while [ $(( $(date +%s) - program_start )) -lt 20 ]; do
  status=$(ctl status) || fail "no status while the program runs"
  [ "$(field fault "$status")" = 0 ] || fail "fault during the program: $(field fault_reason "$status")"
  [ "$(field state "$status")" = enabled ] || fail "state during the program: $(field state "$status")"
  if [ "$(field program_running "$status")" = true ]; then
    saw_running=1
  elif [ $saw_running = 1 ]; then
    ended=1
    break
  fi
  sleep 0.05
done
[ $saw_running = 1 ] || fail "no status showed program_running: true within 20 s of run-program"
[ $ended = 1 ] || fail "the program did not end within 20 s of run-program"

# 4. A refusal comes back as exit status 1 with the reason, one line on stderr.
ctl_refused move-to --target-m 1.0
[ "$reply" = "rejected: move_to: target_m 1 m lies outside the soft limits [-0.11, 0.11] m" ] || fail "move-to beyond the soft limits: '$reply'"

# 5. SIGTERM: exit 0 within 2 s.
rc=0
stop_process $pid 20 || rc=$?
[ $rc != 255 ] || fail "clm-servod still running 2 s after SIGTERM"
trap - EXIT
[ $rc = 0 ] || fail "clm-servod exit status $rc after SIGTERM, expected 0"
grep -q "stopping on SIGTERM" "$work/servod.log" || fail "no 'stopping on SIGTERM' in its stderr"

# 6. systemd saw READY first, watchdog pings while it ran, STOPPING last.
wait $listener || true
rm -rf "$notify_dir"
[ "$(head -n 1 "$work/notify.log")" = "READY=1" ] || fail "first notification: '$(head -n 1 "$work/notify.log")'"
[ "$(tail -n 1 "$work/notify.log")" = "STOPPING=1" ] || fail "last notification: '$(tail -n 1 "$work/notify.log")'"
pings=$(grep -cx "WATCHDOG=1" "$work/notify.log" || true)
[ "$pings" -ge 5 ] || fail "$pings WATCHDOG=1 in a run of more than a second at WATCHDOG_USEC=200000"
grep -qx "STATUS=state enabled, fault 0 (none)" "$work/notify.log" || fail "no STATUS= line for the enabled axis"
if grep -q "error" "$work/servod.log"; then fail "an error line in its stderr"; fi
echo "clm-servod process test: refusals, status, enable, program, refused move, SIGTERM, systemd notifications ($pings watchdog pings): all as expected"
