#!/usr/bin/env bash
# Process-level tests of clm-servod's command authority and its handling of
# untrusted datagrams (docs/servod.md "Command authority", docs/reliability.md
# "Untrusted input"): the daemon on the real-time clock at 1 kHz without
# real-time rights, on an LCM port of its own per mode; `clm ctl` as the
# operator types it; raw datagrams from tests/support/send_lcm_datagram.py.
#
#   servod_authority_test.sh MODE CLM_SERVOD CLM SOURCE_DIR WORK_DIR
#
# MODE hostile   the two hostile command datagrams and a flood of 1000 random
#                ones: the daemon keeps cycling, answers, counts them malformed.
#      ctl       enable, move-to, stop typed one after another; a second client
#                can stop and disable but not enable or move; release.
#      presence  a second daemon of the same axis refuses to start; one of
#                another axis starts, and clm ctl's commands then need --axis; a status
#                of the same axis from another session disables the axis.
#      replay    the same MOVE_TO datagram three times runs once; an
#                lcm-logger log of a clm ctl session replayed onto a restarted
#                daemon moves nothing.
#      spoof     another process without the operators' key forges the
#                daemon's status (a disabled axis, another calibration file)
#                and accepted acks of every command (tests/support/spoof_lcm.py):
#                clm ctl status, a refused command and clm ctl save show and
#                write the daemon's own answers, never the forged ones.
set -euo pipefail
mode=$1 servod=$2 clm=$3 source_dir=$4 work=$5
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"
send="$source_dir/tests/support/send_lcm_datagram.py"
channels="$source_dir/tests/support/lcm_log_channels.py"
corpus="$source_dir/tests/fuzz/corpus/lcm_datagram"

# A port of its own per mode (10000..10159 and 10280..10319; the other LCM
# tests use 7700..9989, tests/servod/test_axis_presence.cpp 10160..10199).
case $mode in
  hostile) base=10000 ;; ctl) base=10040 ;; presence) base=10080 ;; replay) base=10120 ;; spoof) base=10280 ;;
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


# Starts a daemon on CONFIG (stderr to LOG) and waits for its status: sets pid.
up() {  # CONFIG LOG
  start_daemon "$1" "$2"
  pid=$servod_pid
  local rc=0
  wait_for_status "$pid" 20 || rc=$?
  [ $rc != 2 ] || fail "clm-servod on $1 exited at start-up"
  [ $rc = 0 ] || fail "clm-servod on $1: no status within 20 s"
}

# The seconds since the epoch, with a fraction; the seconds since START.
now_s() { date +%s.%N; }
since() { echo "$(now_s) - $1" | bc; }

# wait_commands STATUS_BEFORE N SECONDS NAME...: polls `clm ctl status` until
# the counts NAME... of its commands line have grown by N together since
# STATUS_BEFORE, at most SECONDS (the command thread of a loaded host may take
# its time): sets `s` to the last status; 1 if they never did.
wait_commands() {
  local before=$1 n=$2 seconds=$3 start grown name
  shift 3
  start=$(now_s)
  while :; do
    s=$(ctl status) || fail "no status while waiting for the daemon to count $n commands"
    grown=0
    for name in "$@"; do grown=$(( grown + $(commands "$s" "$name") - $(commands "$before" "$name") )); done
    [ "$grown" -ge "$n" ] && return 0
    [ "$(echo "$(since "$start") < $seconds" | bc)" = 1 ] || return 1
    sleep 0.1
  done
}

# wait_not_running WHAT SECONDS: polls until no program runs, at most SECONDS: sets `s`.
wait_not_running() {
  local start
  start=$(now_s)
  while :; do
    s=$(ctl status) || fail "$1: no status"
    [ "$(field program_running "$s")" = false ] && return 0
    [ "$(echo "$(since "$start") < $2" | bc)" = 1 ] || fail "$1: a program still runs after $2 s"
    sleep 0.1
  done
}

# start_command_logger LOG: lcm-logger on CLM_SERVO_COMMAND and the probe
# channel CLM_TEST_LOGGER_PROBE into LOG; returns once a probe datagram (sent
# every 0.2 s) is in the log, i.e. the logger has subscribed and records the
# commands that follow, at most 10 s. Sets logger_pid. Nothing listens on the
# probe channel, so replaying the log replays the probes to no one.
start_command_logger() {
  local start
  lcm-logger -q --lcm-url="$url" --channel="CLM_SERVO_COMMAND|CLM_TEST_LOGGER_PROBE" "$1" 2> "$work/logger.log" &
  logger_pid=$!
  pids+=("$logger_pid")
  start=$(now_s)
  while :; do
    python3 "$send" "$url" CLM_TEST_LOGGER_PROBE "$corpus/command-move-to" --skip 1 || fail "sending a logger probe"
    sleep 0.2
    [ -s "$1" ] && [ "$(python3 "$channels" "$1" CLM_TEST_LOGGER_PROBE)" -gt 0 ] && return 0
    [ "$(echo "$(since "$start") < 10" | bc)" = 1 ] ||
        fail "lcm-logger: no probe datagram in $1 within 10 s of its start: $(cat "$work/logger.log")"
  done
}

# start_state_logger LOG: lcm-logger on CLM_SERVO_STATE into LOG; returns once
# the log holds a state (wait_log_started, at most 10 s). Sets logger_pid.
start_state_logger() {
  record_states "$1" "$work/logger2.log"
  wait_log_started "$1" 10 || fail "lcm-logger: no state in $1 within $waited_s s of its start: $(cat "$work/logger2.log")"
}

# The count after NAME in the `commands:` line of STATUS.
commands() { field commands "$1" | sed -n "s/\(^\|.*[ ,]\)$2 \([0-9]*\).*/\2/p"; }
# `clm ctl` that may fail: output in `reply`, exit status in `rc`.
try_ctl() { set +e; reply=$(ctl "$@" 2>&1); rc=$?; set -e; }

process_test_config "$work/servod.yaml" "  lock_memory: false"

case $mode in
# ---------------------------------------------------------------------------------
hostile)
  up "$work/servod.yaml" "$work/servod.log"
  before=$(ctl status)
  [ "$(commands "$before" malformed)" = 0 ] || fail "malformed before anything was sent: $(field commands "$before")"
  # The datagram that crashed the daemon (lcm-gen's decode of a negative
  # string length) in the earlier layout and in the present one.
  for f in command-program-length-min-int32-earlier-layout command-program-length-min-int32; do
    python3 "$send" "$url" CLM_SERVO_COMMAND "$corpus/$f" --skip 1 || fail "sending $f"
  done
  # 1000 random datagrams: 500 wholly random, 500 with servo_command_t's hash and a random rest.
  python3 "$send" "$url" CLM_SERVO_COMMAND "$corpus/command-move-to" --skip 1 --count 500 --random-tail 0 \
      --pause-every 20 || fail "sending the random datagrams"
  python3 "$send" "$url" CLM_SERVO_COMMAND "$corpus/command-move-to" --skip 1 --count 500 --random-tail 8 \
      --pause-every 20 || fail "sending the random datagrams with the hash"
  kill -0 "$pid" 2>/dev/null || fail "clm-servod died on the datagrams"
  # The command thread counts what reached it (at most 10 s; a few may be
  # lost in the socket buffer on a loaded host, hence 990).
  wait_commands "$before" 990 10 malformed || true  # the check below says what was counted
  kill -0 "$pid" 2>/dev/null || fail "clm-servod died on the datagrams"
  first=$(ctl status) || fail "no status after the datagrams"
  second=$(ctl status) || fail "no second status after the datagrams"
  [ "$(field cycles "$second")" -gt "$(field cycles "$first")" ] ||
      fail "cycles do not advance: $(field cycles "$first") then $(field cycles "$second")"
  [ "$(field cycles "$first")" -gt "$(field cycles "$before")" ] || fail "cycles did not advance over the flood"
  malformed=$(commands "$second" malformed)
  [ "$malformed" -ge 990 ] && [ "$malformed" -le 1002 ] ||
      fail "commands_refused_malformed $malformed after 2 hostile and 1000 random datagrams (waited up to 10 s), expected 990..1002"
  [ "$(commands "$second" admitted)" = 0 ] || fail "a random datagram was admitted: $(field commands "$second")"
  reply=$(ctl enable) || fail "enable after the flood: $reply"
  [ "$reply" = accepted ] || fail "enable after the flood: '$reply'"
  echo "hostile datagrams: 2 crafted + 1000 random, $malformed counted malformed, cycles $(field cycles "$first") -> $(field cycles "$second"), enable accepted after"
  ;;
# ---------------------------------------------------------------------------------
ctl)
  up "$work/servod.yaml" "$work/servod.log"
  reply=$(ctl enable) || fail "enable: $reply"
  [ "$reply" = accepted ] || fail "enable: '$reply'"
  reply=$(ctl move-to --target-m 0.005) || fail "move-to: $reply"
  [ "$reply" = "program posted" ] || fail "move-to: '$reply'"
  reply=$(ctl stop) || fail "stop: $reply"
  [ "$reply" = accepted ] || fail "stop: '$reply'"
  s=$(ctl status)
  holder=$(field control_client "$s")
  [ "$holder" != 0 ] || fail "nobody holds control after enable and move-to"
  lease=$(field control_lease_remaining_s "$s")
  [ "$(echo "$lease > 1" | bc)" = 1 ] || fail "lease left $lease s"
  # Another client: neither enable nor move, but stop and disable.
  try_ctl --client-id 4242 move-to --target-m 0.0
  [ $rc = 1 ] || fail "move-to of another client while $holder holds control: exit $rc ($reply)"
  grep -q "not_in_control" <<< "$reply" || fail "move-to of another client: '$reply'"
  try_ctl --client-id 4242 enable
  [ $rc = 1 ] || fail "enable of another client: exit $rc ($reply)"
  grep -q "not_in_control" <<< "$reply" || fail "enable of another client: '$reply'"
  reply=$(ctl --client-id 4242 stop) || fail "stop of another client refused: $reply"
  reply=$(ctl --client-id 4242 disable) || fail "disable of another client refused: $reply"
  s=$(ctl status)
  [ "$(field state "$s")" = disabled ] || fail "state after the other client's disable: $(field state "$s")"
  [ "$(field control_client "$s")" = "$holder" ] || fail "stop/disable moved control to $(field control_client "$s")"
  # The holder goes on without typing anything more; then releases.
  reply=$(ctl enable) || fail "enable again: $reply"
  reply=$(ctl release) || fail "release: $reply"
  [ "$reply" = "control released" ] || fail "release: '$reply'"
  reply=$(ctl --client-id 4242 enable) || fail "enable of the other client after the release: $reply"
  s=$(ctl --client-id 4242 status)
  [ "$(field control_client "$s")" = 4242 ] || fail "control after the release and enable: $(field control_client "$s")"
  [ "$(commands "$s" not_in_control)" = 2 ] || fail "not_in_control refusals: $(field commands "$s")"
  echo "clm ctl: enable, move-to, stop typed in turn; client 4242 refused enable/move, obeyed for stop/disable; release: $(field commands "$s")"
  ;;
# ---------------------------------------------------------------------------------
presence)
  up "$work/servod.yaml" "$work/servod.log"
  first_pid=$pid
  session=$(field session "$(ctl status)")
  # Same axis, same URL: exit 2, one line naming axis, URL and the session.
  set +e
  "$servod" --config "$work/servod.yaml" --duration-s 2 2> "$work/second.err"
  rc=$?
  set -e
  [ $rc = 2 ] || fail "second daemon of axis0: exit $rc, expected 2"
  [ "$(wc -l < "$work/second.err")" = 1 ] || fail "second daemon: not one line: $(cat "$work/second.err")"
  for part in "axis 'axis0'" "$url" "session $session"; do
    grep -qF -- "$part" "$work/second.err" || fail "second daemon's line lacks '$part': $(cat "$work/second.err")"
  done
  kill -0 "$first_pid" 2>/dev/null || fail "the first daemon died"
  # Another axis on the same URL starts; clm ctl then wants --axis.
  process_test_config "$work/servod-axis1.yaml" "  lock_memory: false"
  printf 'axis:\n  name: axis1\n' >> "$work/servod-axis1.yaml"
  start_daemon "$work/servod-axis1.yaml" "$work/axis1.log"
  axis1_pid=$servod_pid
  ok=0
  for _ in $(seq 1 8); do
    if s=$(ctl --axis axis1 status --timeout-s 1 2>/dev/null); then ok=1; break; fi
  done
  [ $ok = 1 ] || fail "no status of axis1"
  [ "$(field axis "$s")" = axis1 ] || fail "--axis axis1 status names axis $(field axis "$s")"
  try_ctl enable
  [ $rc = 2 ] || fail "enable with two axes and no --axis: exit $rc ($reply)"
  grep -qF "'axis0', 'axis1'" <<< "$reply" || fail "the refusal does not list both axes: $reply"
  s=$(ctl status) || fail "status without --axis (the first axis heard)"
  grep -qx "axis: axis[01]" <<< "$s" || fail "status without --axis names $(field axis "$s")"
  reply=$(ctl --axis axis0 enable) || fail "enable of axis0 with --axis: $reply"
  s=$(ctl --axis axis0 status)
  [ "$(field state "$s")" = enabled ] || fail "axis0 not enabled: $(field state "$s")"
  # At run time: a status of axis0 from another session (a forged one,
  # session 42) makes the daemon disable the axis and say so in an event.
  lcm-logger -q --lcm-url="$url" --channel="CLM_SERVO_EVENT|CLM_TEST_LOGGER_PROBE" "$work/events.lcmlog" \
      2> "$work/logger.log" &
  logger_pid=$!
  pids+=("$logger_pid")
  # The logger has subscribed once a probe datagram is in its log (at most 10 s).
  start=$(now_s)
  until [ -s "$work/events.lcmlog" ] && [ "$(python3 "$channels" "$work/events.lcmlog" CLM_TEST_LOGGER_PROBE)" -gt 0 ]; do
    [ "$(echo "$(since "$start") < 10" | bc)" = 1 ] || fail "lcm-logger: no probe datagram in its log within 10 s"
    python3 "$send" "$url" CLM_TEST_LOGGER_PROBE "$corpus/command-move-to" --skip 1 || fail "sending a logger probe"
    sleep 0.2
  done
  python3 "$send" "$url" CLM_SERVO_STATUS "$corpus/status-fault" --skip 1 --sign || fail "sending the forged status"
  start=$(now_s)
  until s=$(ctl --axis axis0 status) && [ "$(field state "$s")" = disabled ]; do
    [ "$(echo "$(since "$start") < 10" | bc)" = 1 ] ||
        fail "axis0 still $(field state "$s") 10 s after another session's status"
  done
  # The daemon's error event naming session 42, in the log once the logger
  # has written it (at most 10 s).
  start=$(now_s)
  until grep -qa "axis axis0 is also driven by session 42" "$work/events.lcmlog"; do
    [ "$(echo "$(since "$start") < 10" | bc)" = 1 ] ||
        fail "no error event naming session 42 in the event log 10 s after the axis was disabled ($(python3 "$channels" "$work/events.lcmlog" CLM_SERVO_EVENT) CLM_SERVO_EVENT logged)"
    sleep 0.2
  done
  kill -INT "$logger_pid"; wait "$logger_pid" || true
  kill -0 "$first_pid" 2>/dev/null || fail "the first daemon died"
  kill -0 "$axis1_pid" 2>/dev/null || fail "the axis1 daemon died"
  echo "presence: second axis0 refused ($(cat "$work/second.err")); axis1 beside it needs --axis; a foreign status disabled axis0"
  ;;
# ---------------------------------------------------------------------------------
replay)
  up "$work/servod.yaml" "$work/servod.log"
  # (a) The same MOVE_TO datagram three times: client 77 takes control,
  # then one datagram with this session, a fresh utime and a sequence above
  # its earlier ones (wall-clock nanoseconds, as clm ctl counts) is sent thrice.
  reply=$(ctl --client-id 77 enable) || fail "enable: $reply"
  session=$(field session "$(ctl status)")
  before=$(ctl status)
  python3 "$send" "$url" CLM_SERVO_COMMAND "$corpus/command-move-to" --skip 1 --sign --count 3 \
      --set-int64 "34=$session" --set-int64 42=77 --set-int64 "16=$(date +%s%N)" --utime-now 8 || fail "sending the MOVE_TO"
  # The three counted, admitted or refused as replayed (at most 10 s).
  wait_commands "$before" 3 10 admitted replayed ||
      fail "the MOVE_TO sent 3 times: admitted and refused as replayed $(( $(commands "$s" admitted) + $(commands "$s" replayed) - $(commands "$before" admitted) - $(commands "$before" replayed) )) times within 10 s, expected 3: $(field commands "$s")"
  admitted=$(( $(commands "$s" admitted) - $(commands "$before" admitted) ))
  replayed=$(( $(commands "$s" replayed) - $(commands "$before" replayed) ))
  [ $admitted = 1 ] || fail "the MOVE_TO sent 3 times was admitted $admitted times, expected once"
  [ $replayed = 2 ] || fail "the MOVE_TO sent 3 times: $replayed refused as replayed, expected 2"
  wait_not_running "the MOVE_TO" 20
  [ "$(field fault "$s")" = 0 ] || fail "fault after the move: $(field fault_reason "$s")"
  # (b) A clm ctl session recorded with lcm-logger ...
  reply=$(ctl release --client-id 77) || fail "release: $reply"
  start_command_logger "$work/session.lcmlog"
  session_before=$(ctl status)
  reply=$(ctl enable) || fail "enable in the recorded session: $reply"
  reply=$(ctl move-to --target-m 0.02) || fail "move-to in the recorded session: $reply"
  # Every command the daemon admitted in the session is in the log before the
  # logger stops (at most 10 s): what the restarted daemon must refuse.
  session_after=$(ctl status)
  session_admitted=$(( $(commands "$session_after" admitted) - $(commands "$session_before" admitted) ))
  [ "$session_admitted" -ge 3 ] ||
      fail "the recorded session: $session_admitted commands admitted, expected take, enable and move-to: $(field commands "$session_after")"
  start=$(now_s)
  until [ "$(python3 "$channels" "$work/session.lcmlog" CLM_SERVO_COMMAND)" -ge "$session_admitted" ]; do
    [ "$(echo "$(since "$start") < 10" | bc)" = 1 ] ||
        fail "the session log holds $(python3 "$channels" "$work/session.lcmlog" CLM_SERVO_COMMAND) CLM_SERVO_COMMAND datagrams 10 s after the session, the daemon admitted $session_admitted"
    sleep 0.2
  done
  kill -INT "$logger_pid"; wait "$logger_pid" || true
  recorded=$(python3 "$channels" "$work/session.lcmlog" CLM_SERVO_COMMAND)
  rc=0; stop_process "$pid" 30 || rc=$?
  [ $rc = 0 ] || fail "clm-servod exit $rc after SIGTERM"
  # ... replayed onto a restarted daemon, enabled by client 5, moves nothing:
  # the setpoint r_m of every state recorded meanwhile stays where it was.
  up "$work/servod.yaml" "$work/servod2.log"
  reply=$(ctl --client-id 5 enable) || fail "enable of the restarted daemon: $reply"
  reply=$(ctl --client-id 5 release) || fail "release of the restarted daemon: $reply"
  start_state_logger "$work/states.lcmlog"
  replay_from=$log_last  # a state before the replay is in the log
  replay_before=$(ctl status)
  lcm-logplayer --lcm-url="$url" "$work/session.lcmlog" > "$work/logplayer.log" 2>&1 || fail "lcm-logplayer failed"
  # Every replayed command counted (refused as other_session, or admitted), at most 10 s.
  wait_commands "$replay_before" "$recorded" 10 other_session admitted ||
      fail "the replayed log of $recorded commands: $(( $(commands "$s" other_session) - $(commands "$replay_before" other_session) )) refused as other_session and $(( $(commands "$s" admitted) - $(commands "$replay_before" admitted) )) admitted within 10 s: $(field commands "$s")"
  # 0.5 s of cycles after the last replayed command in the state log (a
  # replayed move-to would have moved the setpoint by then), at most 10 s.
  until_cycle=$(( $(field cycles "$s") + 500 ))
  wait_log_reaches "$work/states.lcmlog" "$until_cycle" 10 ||
      fail "the state log reached cycle $log_last ($log_states states) $waited_s s after the replay, needed cycle $until_cycle (0.5 s after the replayed commands were counted)"
  kill -INT "$logger_pid"; wait "$logger_pid" || true
  s=$(ctl status)
  [ "$(commands "$s" admitted)" = 3 ] || fail "the restarted daemon admitted more than client 5's three (take, enable, release): $(field commands "$s")"
  other=$(commands "$s" other_session)
  [ "$other" -ge 3 ] || fail "the replayed log: $other refused as other_session, expected at least 3 (take, enable, move-to): $(field commands "$s")"
  [ "$(field program_running "$s")" = false ] || fail "a program runs after the replay"
  "$clm" log2csv --log "$work/states.lcmlog" --output "$work/states.csv" --format full > /dev/null ||
      fail "log2csv of the states"
  verdict=$(py_check "$work/states.csv" "$replay_from" "$until_cycle" <<'CHECK'
import csv, sys
rows = list(csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith("#")))
replay_from, until_cycle = int(sys.argv[2]), int(sys.argv[3])
cycles = [int(float(row["cycle"])) for row in rows]
assert rows and cycles[0] <= replay_from and cycles[-1] >= until_cycle, \
    f"the state log spans cycles {cycles[0] if rows else '-'}..{cycles[-1] if rows else '-'}, not {replay_from}..{until_cycle}"
r = [float(row["r_m"]) for row in rows]
assert max(r) == min(r), f"the setpoint moved during the replay: {min(r)} .. {max(r)} m"
print(f"setpoint {r[0]} m in all {len(rows)} states of cycles {cycles[0]}..{cycles[-1]}")
CHECK
) || fail "replay: $verdict"
  echo "replay: one MOVE_TO datagram sent 3 times admitted once (2 replayed); a recorded clm ctl session ($recorded commands) replayed on a restarted daemon: $other refused other_session; $verdict"
  ;;
# ---------------------------------------------------------------------------------
spoof)
  up "$work/servod.yaml" "$work/servod.log"
  reply=$(ctl enable) || fail "enable: $reply"
  python3 "$source_dir/tests/support/spoof_lcm.py" "$url" --duration-s 8 > "$work/spoof.out" 2> "$work/spoof.log" &
  spoof_pid=$!
  pids+=("$spoof_pid")
  sleep 1  # the spoofer has joined the group
  # The status clm ctl prints is the daemon's: enabled, no forged file.
  for _ in 1 2 3; do
    s=$(ctl status) || fail "status under the spoofing"
    [ "$(field state "$s")" = enabled ] || fail "status under the spoofing shows state $(field state "$s"), the axis is enabled"
    ! grep -q spoofed <<< "$s" || fail "status under the spoofing shows the forged file: $(grep spoofed <<< "$s")"
  done
  # A command the daemon refuses stays refused, whatever ack is forged first.
  try_ctl load-calibration "$source_dir/README.md"
  [ $rc = 1 ] || fail "load-calibration of a file outside file_directories under the spoofing: exit $rc ($reply)"
  ! grep -q spoofed <<< "$reply" || fail "load-calibration took the forged ack: $reply"
  # Save writes what the daemon runs, not what was forged.
  cp "$work/servod.yaml" "$work/saved.yaml"
  reply=$(ctl save --config "$work/saved.yaml") || fail "save under the spoofing: $reply"
  ! grep -q spoofed "$work/saved.yaml" || fail "save wrote the forged file: $(grep spoofed "$work/saved.yaml")"
  wait "$spoof_pid" || fail "the spoofer failed: $(cat "$work/spoof.log")"
  forged=$(cat "$work/spoof.out")
  statuses=$(sed -n 's/^spoof: \([0-9]*\) statuses.*/\1/p' <<< "$forged")
  acks=$(sed -n 's/.* and \([0-9]*\) acks.*/\1/p' <<< "$forged")
  [ "${statuses:-0}" -gt 5 ] && [ "${acks:-0}" -ge 2 ] ||
      fail "the spoofer forged too little for the test to mean anything: $forged (bound: > 5 statuses, >= 2 acks)"
  s=$(ctl status)
  echo "spoof: $forged; clm ctl status showed the enabled axis, load-calibration stayed refused, save wrote no forged file; $(field commands "$s")"
  ;;
esac
rc=0
stop_process "$pid" 30 || rc=$?
[ $rc = 0 ] || fail "clm-servod exit $rc after SIGTERM"
