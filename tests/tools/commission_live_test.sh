#!/usr/bin/env bash
# `clm commission --live` against the real clm-servod process over LCM udpm
# (label lcm), on a port of its own.
#
#   commission_live_test.sh run      CLM_SERVOD CLM SOURCE_DIR WORK_DIR
#       the daemon on the embedded simulated motor with the real-time clock,
#       a shortened experiment program; the whole live commissioning with
#       --save; checks the report, the logs, the daemon's clean exit, and that
#       a daemon restarted on the saved configuration commutates with the
#       commissioned PGNN and feedforward. About 2.5 min.
#   commission_live_test.sh no-sensor CLM_SERVOD CLM SOURCE_DIR WORK_DIR
#       the same daemon configured without a force sensor, commissioned from
#       positions alone (--no-force-sensor --save): experiments run on the
#       encoder, only the laws from positions are evaluated, and a daemon
#       restarted on the saved configuration runs the spline law from
#       positions. About 1.5 min.
#   commission_live_test.sh killed CLM_SERVOD CLM SOURCE_DIR WORK_DIR
#       the daemon as for run; `clm commission --live` killed three times:
#       SIGKILL at the first status that shows it holding control (early:
#       within its first experiment's first second on this host), SIGKILL
#       2 s into an experiment program, SIGTERM 2 s into one. Each time, within
#       3 s, the axis is disabled or holding still in the service law (status:
#       commutation not experiment, no program running) and nobody holds
#       control (control_client 0); after SIGTERM the tool exits 1 and says
#       why. About 1 min.
#   commission_live_test.sh resume CLM_SERVOD CLM SOURCE_DIR WORK_DIR
#       the daemon as for run with a fault plan; `clm commission --live`
#       ended by fault 102 (force frames lost, SIGUSR1 to the daemon) during
#       the second experiment; the fault cleared; --resume refused (exit
#       2, within 10 s) when the progress names another configuration; then
#       resumed: experiment 1's log untouched, only the other experiments
#       and the laws run, experiments.csv and the joined experiments.lcm hold
#       all six. About 2.5 min.
#   commission_live_test.sh preflight CLM_SERVOD CLM SOURCE_DIR WORK_DIR
#       the daemon with a simulated drive whose watchdog is 1 ms: `clm
#       commission --live` is refused within 10 s, exit 2, one line naming
#       the watchdog, the measured max wake-up latency (between the status's
#       before and after) and the fix, nothing written, the axis never
#       enabled; the daemon warned of it once at start. About 10 s.
#   commission_live_test.sh no-daemon CLM_SERVOD CLM SOURCE_DIR WORK_DIR
#       nobody answers: one stderr line naming the command, a non-zero exit
#       within the ack timeout, nothing written.
set -euo pipefail
mode=$1 servod=$2 clm=$3 source_dir=$4 work=$5
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"

fail() {
  echo "FAIL: $*" >&2
  for log in "$work/servod.log" "$work/commission.err"; do
    [ -f "$log" ] && { echo "--- $log:" >&2; tail -n 30 "$log" >&2; }
  done
  exit 1
}

# --save: the configuration holds each LINE (comments aside), and a daemon
# started on it comes up with commutation MODE (with an incremental encoder:
# the drive's own law until `home`, MODE once homed); its status is left in
# saved_status, and it exits cleanly on SIGTERM.
check_saved() {
  local mode=$1 line rc
  shift
  for line in "$@"; do
    grep -qxF -- "$line" <(sed 's/ *#.*//' "$work/servod.yaml") || fail "--save: no line '$line' in servod.yaml"
  done
  start_daemon "$work/servod.yaml" "$work/servod-saved.log"
  pid=$servod_pid
  trap 'kill -KILL $pid 2>/dev/null || true' EXIT
  rc=0
  wait_for_status $pid 20 || rc=$?
  [ $rc != 2 ] || fail "the daemon on the saved configuration exited at start-up"
  [ $rc = 0 ] || fail "no status from a daemon on the saved configuration within 20 s"
  saved_status=$(ctl status) || fail "no status on the saved configuration"
  if [[ $(field homing "$saved_status") == *"not homed"* ]]; then
    [ "$(field commutation "$saved_status")" = original ] ||
        fail "saved configuration: commutation $(field commutation "$saved_status") before homing"
    ctl home > /dev/null || fail "home refused on the saved configuration"
    wait_homing "idle, commutation found, homed" 30 || fail "saved configuration: not homed within 30 s: '$homed'"
    saved_status=$status
  fi
  [ "$(field commutation "$saved_status")" = "$mode" ] ||
      fail "saved configuration: commutation $(field commutation "$saved_status")"
  rc=0
  stop_process $pid 20 || rc=$?
  trap - EXIT
  [ $rc = 0 ] || fail "clm-servod on the saved configuration: exit status $rc after SIGTERM"
}

rm -rf "$work"
mkdir -p "$work"

if [ "$mode" = no-daemon ]; then
  # A port no test uses, so no daemon can answer (10590..10619).
  url="udpm://239.255.76.67:$((10590 + $$ % 30))?ttl=0"
  mkdir "$work/out"
  # The configuration (and its programs) beside the output, so that --out
  # passes the directory check and the run gets as far as the daemon.
  sed "s|^motor_file: motor-sim.yaml|motor_file: $source_dir/config/motor-sim.yaml|" "$source_dir/config/servod.yaml" \
      > "$work/servod.yaml"
  cp -r "$source_dir/config/programs" "$work/programs"
  start=$(date +%s.%N)
  set +e
  "$clm" commission --live --lcm-url "$url" --ack-timeout-s 1 --config "$work/servod.yaml" \
      --out "$work/out" --no-plots > "$work/commission.out" 2> "$work/commission.err"
  rc=$?
  "$clm" commission --live --lcm-url "$url" --ack-timeout-s 1 --config "$work/servod.yaml" \
      --out "$work/not-created" --no-plots > /dev/null 2> "$work/commission2.err"
  rc2=$?
  set -e
  elapsed=$(echo "$(date +%s.%N) - $start" | bc)
  # No ack in time is a failure at run time: exit status 1.
  [ $rc = 1 ] || fail "--live without a daemon: exit status $rc, expected 1"
  [ $rc2 = 1 ] || fail "--live without a daemon: exit status $rc2, expected 1 (second run)"
  [ "$(wc -l < "$work/commission.err")" = 1 ] || fail "not one line on stderr: $(cat "$work/commission.err")"
  grep -qF "clm commission: error: no CLM_SERVO_COMMAND_ACK for ENABLE" "$work/commission.err" ||
      fail "the line does not name the command: $(cat "$work/commission.err")"
  grep -qF "within 1 s" "$work/commission.err" || fail "the line does not say the timeout: $(cat "$work/commission.err")"
  # Two runs of a 1 s ack timeout, plus start-up: well under 6 s.
  [ "$(echo "$elapsed < 6" | bc)" = 1 ] || fail "two runs took $elapsed s with --ack-timeout-s 1"
  [ -z "$(ls -A "$work/out")" ] || fail "something was written into the output directory: $(ls -A "$work/out")"
  [ ! -e "$work/not-created" ] || fail "the output directory was created although nothing ran"
  echo "clm commission --live without a daemon: exit $rc after $elapsed s (two runs), one line: $(cat "$work/commission.err")"
  exit 0
fi

if [ "$mode" = preflight ]; then
  url="udpm://239.255.76.67:$((10620 + $$ % 30))?ttl=0"
  # The simulated drive's watchdog at 1 ms, the period itself: no measured
  # wake-up latency leaves it the margin of period + 3 x the max latency
  # (daemon/servo/timing.hpp), on any host. The rest as for run.
  config_edit "$source_dir/config/motor-sim.yaml" "$work/motor-sim.yaml" "  watchdog_timeout_s: 0.001" "${ABSOLUTE_MOTOR[@]}" > /dev/null ||
      fail "motor copy: no watchdog line"
  missing=$(config_edit "$source_dir/config/servod.yaml" "$work/servod.yaml" "${ABSOLUTE_CONFIG[@]}" "motor_file: $work/motor-sim.yaml" \
            "  clock: realtime" "  lcm_url: \"$url\"" "  overrun_limit: 1000") || fail "config: no line '$missing'"
  cp "$source_dir/tests/support/one_stroke_program.yaml" "$work/program.yaml"
  mkdir "$work/out"
  start_daemon "$work/servod.yaml" "$work/servod.log"
  pid=$servod_pid
  trap 'kill -KILL $pid 2>/dev/null || true' EXIT
  rc=0
  wait_for_status $pid 20 || rc=$?
  [ $rc = 0 ] || fail "no CLM_SERVO_STATUS within 20 s (rc $rc)"
  # The daemon's max wake-up latency only grows: read before and after the
  # tool, it brackets the figure the refusal names.
  before=$(field wakeup_latency_s "$(ctl status)" | sed -n 's/.*max \([^ ]*\).*/\1/p')
  start=$(date +%s.%N)
  rc=0
  "$clm" commission --live --lcm-url "$url" --config "$work/servod.yaml" --program "$work/program.yaml" \
      --experiment-program "$work/program.yaml" --validation-program none --out "$work/out" --no-plots \
      > "$work/commission.out" 2> "$work/commission.err" || rc=$?
  elapsed=$(echo "$(date +%s.%N) - $start" | bc)
  status=$(ctl status) || fail "no status after the refusal"
  after=$(field wakeup_latency_s "$status" | sed -n 's/.*max \([^ ]*\).*/\1/p')
  [ $rc = 2 ] || fail "a 1 ms watchdog: exit status $rc, expected 2 (a setting that does not fit)"
  [ "$(echo "$elapsed < 10" | bc)" = 1 ] || fail "the refusal took $elapsed s, expected within 10 s"
  [ "$(wc -l < "$work/commission.err")" = 1 ] || fail "not one line on stderr: $(cat "$work/commission.err")"
  line=$(cat "$work/commission.err")
  for words in "refused before the first experiment" "drive.watchdog_timeout_s 1 ms" "wake-up latency" \
               "Fix:" "raise drive.watchdog_timeout_s" "$work/motor-sim.yaml"; do
    grep -qF -- "$words" <<< "$line" || fail "the refusal does not say '$words': $line"
  done
  # The figures: the max it names lies between the status's before and after
  # (rounded to 3 digits), and the watchdog it asks for is 1 ms + 3 x that max.
  verdict=$(py_check "$line" "$before" "$after" <<'CHECK'
import re, sys
line, before, after = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
named = float(re.search(r"latency \(max ([0-9.e+-]+) ms", line).group(1)) * 1e-3
# ctl status prints 2 digits (%.1e), the refusal 3: 5 % either way.
assert before * 0.95 <= named and named <= after * 1.05, \
    f"the refusal names a max latency of {named} s, the status said {before} s before and {after} s after"
required = float(re.search(r"to at least ([0-9.e+-]+) ms", line).group(1)) * 1e-3
expected = 1e-3 + 3 * named
# both printed to 3 digits
assert abs(required - expected) <= 0.01 * expected, f"asks for {required} s, expected 1 ms + 3 x {named} s = {expected} s"
print(f"max latency {named * 1e3:.3g} ms (status: {before * 1e3:.3g} .. {after * 1e3:.3g} ms), watchdog asked {required * 1e3:.3g} ms")
CHECK
) || fail "the refusal's figures: $verdict"
  # Refused before anything: nothing written, never enabled, control free.
  [ -z "$(ls -A "$work/out")" ] || fail "written into --out: $(ls -A "$work/out")"
  [ "$(field state "$status")" = disabled ] || fail "the axis is $(field state "$status") after the refusal"
  [ "$(field control_client "$status")" = 0 ] || fail "control held after the refusal"
  # The daemon's own start-up warning (one line, the same rule), once it has
  # run a second.
  for _ in $(seq 1 50); do
    grep -q "clm-servod: warning: timing margin:" "$work/servod.log" && break
    sleep 0.1
  done
  warnings=$(grep -c "clm-servod: warning: timing margin:" "$work/servod.log" || true)
  [ "$warnings" = 1 ] || fail "clm-servod's start-up timing warning: $warnings lines, expected 1"
  grep "clm-servod: warning: timing margin:" "$work/servod.log" | grep -qF "drive.watchdog_timeout_s 1 ms" ||
      fail "the daemon's warning does not name the watchdog: $(grep "timing margin" "$work/servod.log")"
  rc=0
  stop_process $pid 20 || rc=$?
  trap - EXIT
  [ $rc = 0 ] || fail "clm-servod exit status $rc after SIGTERM"
  echo "a 1 ms drive watchdog: refused in $elapsed s, exit 2; $verdict; the daemon warned at start"
  exit 0
fi

[ "$mode" = run ] || [ "$mode" = no-sensor ] || [ "$mode" = killed ] || [ "$mode" = resume ] || fail "unknown mode $mode"
# A port range of each mode's own, 10480..10619, above every other test's:
# ctest runs the modes side by side and beside the other process tests (the
# earlier ranges overlapped those of servod_process_test.sh, the authority,
# stall and flood tests, and a killed-commissioning run once reached the
# flood test's daemon).
case "$mode" in
  run) url="udpm://239.255.76.67:$((10480 + $$ % 30))?ttl=0" ;;
  no-sensor) url="udpm://239.255.76.67:$((10510 + $$ % 40))?ttl=0" ;;
  killed) url="udpm://239.255.76.67:$((10550 + $$ % 40))?ttl=0" ;;
  resume) url="udpm://239.255.76.67:$((10690 + $$ % 30))?ttl=0" ;;
esac

# config/servod.yaml as it is (SCHED_FIFO 80 and mlockall where allowed, else
# a warning and without), with our port and a copy of the simulated motor
# whose drive watchdog is 1 s instead of 5 ms: on the shared 2-core
# development machine (load average 8-10) the loop thread stalled for up to
# 99 ms even at SCHED_FIFO 80, and the 5 ms watchdog latched fault 206 in
# some runs; in a clean-clone CI run beside other tests 5 consecutive
# overruns latched fault 205, so the copy allows 1000 (the largest accepted).
# This test is about the LCM path, not about real-time timing, nor homing
# (commission_live_homing_test.sh): the encoder absolute (ABSOLUTE_MOTOR,
# ABSOLUTE_CONFIG).
# The watchdog at 1 s, not 100 ms: commissioning refuses a watchdog below
# the period + 3 x the measured max wake-up latency (daemon/servo/timing.hpp).
config_edit "$source_dir/config/motor-sim.yaml" "$work/motor-sim.yaml" "  watchdog_timeout_s: 1" "${ABSOLUTE_MOTOR[@]}" > /dev/null ||
    fail "motor copy: watchdog not relaxed"
missing=$(config_edit "$source_dir/config/servod.yaml" "$work/servod.yaml" "${ABSOLUTE_CONFIG[@]}" "motor_file: $work/motor-sim.yaml" \
          "  clock: realtime" "  lcm_url: \"$url\"" "  overrun_limit: 1000" &&
          config_require "$work/servod.yaml" "  rate_hz: 1000" "  state_decimation: 1") ||
    fail "config: no line '$missing' after editing"
# Where the motor file describes the drive's current loop, the six
# experiments first run once on the drive's law, also when resumed
# (docs/commutation.md, "The experiments' back-EMF").
export FIRST_PASS_RUNS=0
if grep -q "^  current_loop:" "$work/motor-sim.yaml"; then FIRST_PASS_RUNS=6; fi

if [ "$mode" = no-sensor ]; then
  sed -i '/^  force_sensor_node_id:/d' "$work/servod.yaml"
  ! grep -q "force_sensor_node_id" "$work/servod.yaml" || fail "config: force_sensor_node_id still there"
fi
if [ "$mode" = resume ]; then
  # One SIGUSR1 to the daemon loses the next 10 force-sensor frames: fault
  # 102 in an experiment (docs/reliability.md, "Fault injection").
  sed -i 's|^  interface: sim\( .*\)\?$|  interface: sim\n  sim_fault_plan: "drop-force:10"|' "$work/servod.yaml"
  grep -q '^  sim_fault_plan: "drop-force:10"' "$work/servod.yaml" || fail "config: no sim_fault_plan"
fi

# The Fig. 8 stroke once out and back (4.6 s a run instead of Fig. 8's 26 s),
# for the experiments and the evaluation, so the 14-16 runs fit in about two
# minutes.
cp "$source_dir/tests/support/one_stroke_program.yaml" "$work/program.yaml"

start_daemon "$work/servod.yaml" "$work/servod.log"
pid=$servod_pid
trap 'kill -KILL $pid 2>/dev/null || true' EXIT
rc=0
wait_for_status $pid 20 || rc=$?
[ $rc != 2 ] || fail "clm-servod exited at start-up"
[ $rc = 0 ] || fail "no CLM_SERVO_STATUS within 20 s"

if [ "$mode" = killed ]; then
  # Independent of the tool: the daemon's configured law, read before any commissioning.
  status=$(ctl status) || fail "no status before commissioning"
  service=$(field commutation "$status")
  [ -n "$service" ] && [ "$service" != experiment ] || fail "the configured law is '$service'"
  # kill_commission NAME SIGNAL CONDITION: starts clm commission --live, waits
  # (up to 60 s) until `ctl status` satisfies CONDITION (a function of the
  # status text), sends SIGNAL, and then requires within 3 s: no control
  # held, and the axis disabled or enabled in the service law with no
  # program running.
  kill_commission() {
    local name=$1 signal=$2 condition=$3 tool start elapsed reached=0 rc=0
    "$clm" commission --live --lcm-url "$url" --config "$work/servod.yaml" --program "$work/program.yaml"         --experiment-program "$work/program.yaml" --validation-program none --out "$work/out-$name" --no-plots         > "$work/commission-$name.out" 2> "$work/commission.err" &
    tool=$!
    start=$(date +%s)
    while [ $(( $(date +%s) - start )) -lt 60 ]; do
      kill -0 $tool 2>/dev/null || fail "$name: clm commission ended before the kill point: $(tail -n 1 "$work/commission.err")"
      status=$(ctl status --timeout-s 1 2>/dev/null) || continue
      if $condition "$status"; then reached=1; break; fi
    done
    [ $reached = 1 ] || { kill -KILL $tool; fail "$name: the kill point not reached within 60 s: $status"; }
    kill -"$signal" $tool
    start=$(date +%s.%N)
    local at="killed at: commutation $(field commutation "$status"), program_running $(field program_running "$status"), program_time_s $(field program_time_s "$status")"

    wait $tool || rc=$?
    while :; do
      status=$(ctl status --timeout-s 1 2>/dev/null) || status=""
      elapsed=$(echo "$(date +%s.%N) - $start" | bc)  # when this status was in
      if [ -n "$status" ] && [ "$(field control_client "$status")" = 0 ] &&
         { [ "$(field state "$status")" = disabled ] ||
           { [ "$(field state "$status")" = enabled ] && [ "$(field commutation "$status")" = "$service" ] &&
             [ "$(field program_running "$status")" = false ]; }; }; then
        break
      fi
      [ "$(echo "$elapsed < 3" | bc)" = 1 ] ||
          fail "$name: $elapsed s after SIG$signal: control_client $(field control_client "$status"), state" \
               "$(field state "$status"), commutation $(field commutation "$status") (service law $service)," \
               "program_running $(field program_running "$status"), fault $(field fault "$status")" \
               "($(field fault_reason "$status"))"
    done
    grep -qx "fault: 0" <<< "$status" || fail "$name: a fault after the kill: $status"
    echo "$name: SIG$signal ($at); after $elapsed s: state $(field state "$status"), commutation" \
         "$(field commutation "$status"), program_running false, control_client 0 (tool exit $rc)"
    if [ "$signal" = TERM ]; then
      [ $rc = 1 ] || fail "$name: clm commission exit status $rc after SIGTERM, expected 1"
      grep -q "interrupted by SIGTERM" "$work/commission.err" ||
          fail "$name: stderr does not say why: $(tail -n 2 "$work/commission.err")"
    fi
  }
  holds_control() { [ "$(field control_client "$1")" != 0 ]; }
  in_experiment() {
    [ "$(field commutation "$1")" = experiment ] && [ "$(field program_running "$1")" = true ] &&
    [ "$(echo "$(field program_time_s "$1") >= 2" | bc)" = 1 ]
  }
  kill_commission early KILL holds_control
  kill_commission experiment KILL in_experiment
  kill_commission experiment-term TERM in_experiment
  rc=0
  stop_process $pid 20 || rc=$?
  trap - EXIT
  [ $rc = 0 ] || fail "clm-servod exit status $rc after SIGTERM"
  exit 0
fi

if [ "$mode" = resume ]; then
  out="$work/out"
  live_args=(--live --lcm-url "$url" --config "$work/servod.yaml" --program "$work/program.yaml"
             --experiment-program "$work/program.yaml" --validation-program none --no-plots)
  # Interrupted by a fault: once the first experiment is listed as complete
  # and the second runs, the daemon loses force-sensor frames (SIGUSR1).
  "$clm" commission "${live_args[@]}" --out "$out" > "$work/commission-1.out" 2> "$work/commission.err" &
  tool=$!
  start=$(date +%s)
  # Experiments listed as complete in the progress file (0 before it exists).
  completed() { if [ -f "$out/commission-progress.yaml" ]; then grep -c "coil_set:" "$out/commission-progress.yaml" || true; else echo 0; fi; }
  while :; do
    kill -0 $tool 2>/dev/null || fail "clm commission ended before its second experiment ran: $(tail -n 1 "$work/commission.err")"
    [ $(( $(date +%s) - start )) -lt 120 ] || { kill -KILL $tool; fail "the second experiment did not run within 120 s"; }
    if [ "$(completed)" -ge 1 ]; then
      status=$(ctl status --timeout-s 1 2>/dev/null) || continue
      [ "$(field commutation "$status")" = experiment ] && [ "$(field program_running "$status")" = true ] && break
    fi
    sleep 0.1
  done
  kill -USR1 $pid
  rc=0
  wait $tool || rc=$?
  [ $rc = 1 ] || fail "clm commission after the fault: exit status $rc, expected 1"
  grep -q "latched fault\|fault 102" "$work/commission.err" ||
      fail "clm commission did not end on the fault: $(tail -n 1 "$work/commission.err")"
  completed=$(completed)
  [ "$completed" -ge 1 ] && [ "$completed" -lt 6 ] || fail "$completed experiments listed as complete after the fault"
  # clm ctl took control to clear the fault: it gives it back for the resume.
  ctl clear-fault > /dev/null || fail "clear-fault after the injected fault"
  ctl release > /dev/null || fail "release after clear-fault"
  [ -f "$out/INCOMPLETE" ] || fail "the interrupted directory is not marked INCOMPLETE"
  first_sha=$(sha256sum "$out/logs/experiment-1.lcm" | cut -d' ' -f1)
  grep -qF "$first_sha" "$out/commission-progress.yaml" || fail "the progress file does not hold experiment 1's SHA-256"
  # Another configuration recorded: refused within 10 s, nothing run.
  cp "$out/commission-progress.yaml" "$work/progress.yaml"
  sed -i "s/^configuration_sha256: .*/configuration_sha256: \"$(printf '0%.0s' $(seq 1 64))\"/" \
      "$out/commission-progress.yaml"
  t0=$(date +%s.%N)
  rc=0
  "$clm" commission "${live_args[@]}" --resume "$out" > /dev/null 2> "$work/refused.err" || rc=$?
  t=$(echo "$(date +%s.%N) - $t0" | bc)
  [ $rc = 2 ] || fail "--resume with another configuration recorded: exit $rc, expected 2: $(cat "$work/refused.err")"
  [ "$(echo "$t < 10" | bc)" = 1 ] || fail "the --resume refusal took $t s"
  for words in "--resume" "daemon's configuration" "Fix:"; do
    grep -qF -- "$words" "$work/refused.err" || fail "the --resume refusal does not say '$words': $(cat "$work/refused.err")"
  done
  cp "$work/progress.yaml" "$out/commission-progress.yaml"
  # Resumed: the completed experiments reused, the rest and the laws run.
  "$clm" commission "${live_args[@]}" --resume "$out" > "$work/commission.out" 2> "$work/commission.err" ||
      fail "clm commission --resume failed: $(tail -n 1 "$work/commission.err")"
  [ ! -e "$out/INCOMPLETE" ] || fail "INCOMPLETE left after the resumed run"
  [ "$(sha256sum "$out/logs/experiment-1.lcm" | cut -d' ' -f1)" = "$first_sha" ] ||
      fail "experiment 1's log was rewritten: it was run again"
  "$clm" log2csv --log "$out/logs/experiments.lcm" --format experiment --output "$work/experiments-from-log.csv" \
      --fail-on-gaps || fail "log2csv of the joined logs/experiments.lcm"
  verdict=$(py_check "$out/report.json" "$out/experiments.csv" "$work/experiments-from-log.csv" "$completed" <<'CHECK'
import csv, json, os, sys
report = json.load(open(sys.argv[1]))
completed = int(sys.argv[4])
rows = list(csv.DictReader(open(sys.argv[2])))
pairs = sorted({(int(float(r["coil_set"])), float(r["delta_rad"]) > 0) for r in rows})
assert pairs == [(l, d) for l in (1, 2, 3) for d in (False, True)], f"experiments.csv holds {pairs}"
from_log = sum(1 for _ in open(sys.argv[3])) - 1
assert from_log == len(rows), f"experiments.lcm has {from_log} experiment rows, experiments.csv {len(rows)}"
c = report["commutations"]
chosen = [t for t in report["selection"]["pgnn"]["trials"] if t["chosen"]][0]["capacity"]
evaluated = 6 if chosen != "pgnn 2/16 Lambda 0.1" and c["pgnn-paper"]["evaluated"] else 5
runs = report["live"]["runs"]
first_pass = int(os.environ["FIRST_PASS_RUNS"])
assert runs == first_pass + 6 - completed + 2 * evaluated, \
    f"{runs} live runs, expected {first_pass} + {6 - completed} experiments + 2 x {evaluated} laws ({completed} reused)"
assert any(f"resumed: {completed} of 6 experiments reused" in n for n in report["notes"]), report["notes"]
for name in ("original", "classical", "pgnn", "spline"):
    assert c[name]["evaluated"], f"{name} not evaluated"
print(f"resumed: {completed} of 6 experiments reused, {runs} runs made; experiments.csv {len(rows)} rows of 6 experiments")
CHECK
) || fail "the resumed report: $verdict"
  echo "$verdict"
  # A 1 s watchdog and 1000 overruns: the daemon saw no timing risk.
  ! grep -q "timing margin" "$work/servod.log" || fail "clm-servod warned: $(grep "timing margin" "$work/servod.log")"
  rc=0
  stop_process $pid 20 || rc=$?
  trap - EXIT
  [ $rc = 0 ] || fail "clm-servod exit status $rc after SIGTERM"
  exit 0
fi

out="$work/out"
start=$(date +%s.%N)
commission() {
  rm -rf "$out"
  cp "$work/servod.yaml" "$work/servod.before.yaml"
  local sensorless=()
  [ "$mode" = run ] || sensorless=(--no-force-sensor)
  "$clm" commission --live --save --lcm-url "$url" --config "$work/servod.yaml" --program "$work/program.yaml" \
      --experiment-program "$work/program.yaml" "${sensorless[@]}" \
      --validation-program none --out "$out" --no-plots > "$work/commission.out" 2> "$work/commission.err"
}
# On the real-time clock a loop stall of the shared host can latch a fault in
# one of the 14 runs (seen: 203, 207 beside other tests at load 3-8). That is
# the daemon doing its job, not the LCM path this test is about: the fault is
# cleared and the whole commissioning runs once more; any other failure, or a
# second one, fails the test. The first attempt's error stays on stderr.
if ! commission; then
  first=$(tail -n 1 "$work/commission.err")
  case "$first" in
    *"latched fault"*) ;;
    *) fail "clm commission --live failed: $first" ;;
  esac
  echo "commission_live: first attempt: $first; clearing the fault and running once more" >&2
  ctl clear-fault > /dev/null || fail "clear-fault after the first attempt failed"
  ctl release > /dev/null || fail "release after clear-fault"  # control back for the second attempt
  commission || fail "clm commission --live failed twice: $first; then: $(tail -n 1 "$work/commission.err")"
fi
elapsed=$(echo "$(date +%s.%N) - $start" | bc)
cat "$work/commission.out"

# The daemon is still running and healthy, then exits cleanly on SIGTERM.
status=$(ctl status) || fail "no status after commissioning"
grep -qx "fault: 0" <<< "$status" || fail "daemon fault after commissioning: $status"
# Commissioning took control for its run and gave it back at the end.
grep -qx "control_client: 0" <<< "$status" || fail "control not released after commissioning: $status"
grep -q "^commands: admitted [1-9]" <<< "$status" || fail "no command admitted during commissioning: $status"
rc=0
stop_process $pid 20 || rc=$?
[ $rc != 255 ] || fail "clm-servod still running 2 s after SIGTERM"
trap - EXIT
[ $rc = 0 ] || fail "clm-servod exit status $rc after SIGTERM"
if grep -q "error" "$work/servod.log"; then fail "an error line in clm-servod's stderr"; fi

if [ "$mode" = no-sensor ]; then
  # The report: the laws from positions alone, no force anywhere, no state missing.
  verdict=$(py_check "$out/report.json" "$work/servod.yaml" <<'CHECK'
import json, os, re, sys
report = json.load(open(sys.argv[1]))
c = report["commutations"]
assert sorted(c) == ["classical-position", "oracle", "original", "spline-position"], f"the laws in the report: {sorted(c)}"
for name in ("original", "classical-position", "spline-position"):
    assert c[name]["evaluated"], f"{name} not evaluated"
    assert c[name]["commutation_mse"]["filtered"] == [None, None, None], \
        f"{name}: a commutation MSE without a force sensor: {c[name]['commutation_mse']}"
assert report["recommended"]["law"] == "spline-position", f"recommended {report['recommended']}, expected spline-position"
position = report["from_position"]
configured = float(re.search(r"^  mass_kg: *([0-9.eE+-]+)", open(sys.argv[2]).read(), re.MULTILINE).group(1))
assert position["mass_source"] == "control.mass_kg of the configuration" and position["mass_kg"] == configured, \
    f"the mass from positions: {position}, expected {configured} kg from control.mass_kg"
tracking = c["original"]["tracking_mse_m2"] / c["spline-position"]["tracking_mse_m2"]
assert tracking >= 2.0, f"spline-position tracks only {tracking:.2f}x better than the drive's own law, expected 2x"
live = report["live"]
# experiments, then original, classical-position, spline-position
expected = int(os.environ["FIRST_PASS_RUNS"]) + 6 + 2 * 3
assert live["runs"] == expected, f"{live['runs']} live runs, expected {expected}: {live}"
assert live["states_missing"] == 0, f"{live['states_missing']} states missing from the live runs' logs: {live}"
print(f"live, no force sensor: original/spline-position tracking MSE {tracking:.1f}x; {position['summary']}")
CHECK
) || fail "report.json: $verdict"
  echo "$verdict"
  for file in experiments.csv model-pgnn.yaml calibration.yaml model-spline.yaml; do
    [ ! -e "$out/$file" ] || fail "$file written without a force sensor"
  done
  "$clm" log2csv --log "$out/logs/experiments.lcm" --format experiment --output "$work/experiments-from-log.csv" ||
      fail "log2csv of logs/experiments.lcm"
  [ "$(head -n 1 "$work/experiments-from-log.csv")" = "t_s,coil_set,delta_rad,magnitude_N,y_m,ia_A,ib_A" ] ||
      fail "log2csv of a sensorless log: header $(head -n 1 "$work/experiments-from-log.csv")"
  cmp -s "$work/servod.yaml.bak" "$work/servod.before.yaml" || fail "--save: servod.yaml.bak is not the previous file"
  outdir=$(cd "$out" && pwd -P)
  check_saved spline "  calibration_file: \"$outdir/calibration-position.yaml\"" \
      "  spline_model_file: \"$outdir/model-spline-position.yaml\"" \
      "  feedforward_file: \"$outdir/feedforward-spline-position.yaml\"" "  mode: spline"
  echo "clm commission --live --no-force-sensor --save: $elapsed s wall time; restarted on the saved spline law"
  exit 0
fi

# The report: PGNN against the calibrated classical law, no state missing.
[ -f "$out/report.json" ] || fail "no report.json"
verdict=$(py_check "$out/report.json" <<'CHECK'
import json, os, sys
report = json.load(open(sys.argv[1]))
c = report["commutations"]
for name in ("original", "classical", "pgnn", "spline", "spline-position"):
    assert c[name]["evaluated"], f"{name} not evaluated"
assert not c["oracle"]["evaluated"] and "simulation" in c["oracle"]["reason"], \
    f"the oracle: {c['oracle']}, expected not evaluated (simulation only)"
classical, pgnn = c["classical"]["commutation_mse"]["filtered"][0], c["pgnn"]["commutation_mse"]["filtered"][0]
ratio = classical / pgnn
tracking = c["classical"]["tracking_mse_m2"] / c["pgnn"]["tracking_mse_m2"]
assert ratio >= 5.0, f"classical/pgnn y-MSE only {ratio:.2f}x, expected 5x"
live = report["live"]
# 6 experiments, then (feedforward data, evaluation) for original, classical,
# pgnn, spline and spline-position, and for the paper's PGNN when it is not
# the one chosen and the daemon took its model (a refused law is reported
# with the daemon's reason, not run).
chosen = [t for t in report["selection"]["pgnn"]["trials"] if t["chosen"]][0]["capacity"]
paper = c["pgnn-paper"]
paper_run = chosen != "pgnn 2/16 Lambda 0.1" and paper["evaluated"]
if chosen != "pgnn 2/16 Lambda 0.1" and not paper["evaluated"]:
    assert "rejected: load_model" in paper["reason"], f"pgnn-paper not evaluated, and not for a refusal: {paper}"
evaluated = 6 if paper_run else 5
expected = int(os.environ["FIRST_PASS_RUNS"]) + 6 + 2 * evaluated
assert live["runs"] == expected, f"{live['runs']} live runs, expected {expected} ({chosen} chosen): {live}"
assert live["states_missing"] == 0, f"{live['states_missing']} states missing from the live runs' logs: {live}"
assert live["states_recorded"] > 16 * 4000, f"{live['states_recorded']} states recorded, expected more than 16 x 4000: {live}"
assert report["total_wall_time_s"] > 16 * 4.5, \
    f"total wall time {report['total_wall_time_s']} s, less than the runs' real time 16 x 4.5 s: not live?"
print(f"live: classical/pgnn driving-direction commutation MSE {ratio:.1f}x "
      f"(classical {classical:.3g} N^2, pgnn {pgnn:.3g} N^2), tracking MSE {tracking:.1f}x")
CHECK
) || fail "report.json: $verdict"
echo "$verdict"

# The logs, read back independently: every cycle of each run, none missing.
for name in experiments feedforward-data-original evaluation-original feedforward-data-classical evaluation-classical \
            feedforward-data-pgnn evaluation-pgnn feedforward-data-spline evaluation-spline; do
  [ -f "$out/logs/$name.lcm" ] || fail "no logs/$name.lcm"
done
[ -z "$(find "$out" -name '*.tmp')" ] || fail "temporary files left: $(find "$out" -name '*.tmp')"
# --fail-on-gaps: the runs' logs mark the pauses between runs, so no gap is reported (docs/telemetry.md, "Gaps").
"$clm" log2csv --log "$out/logs/evaluation-pgnn.lcm" --format full --output "$work/evaluation-pgnn-full.csv" \
    --fail-on-gaps || fail "log2csv of logs/evaluation-pgnn.lcm"
"$clm" log2csv --log "$out/logs/experiments.lcm" --format experiment --output "$work/experiments-from-log.csv" \
    --fail-on-gaps || fail "log2csv of logs/experiments.lcm"
verdict=$(py_check "$work/evaluation-pgnn-full.csv" "$work/experiments-from-log.csv" "$out/experiments.csv" <<'CHECK'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
cycles = [int(float(r["cycle"])) for r in rows]
assert all(b - a == 1 for a, b in zip(cycles, cycles[1:])), "a gap in the evaluation log's cycles"
assert all(float(r["program_running"]) == 1.0 for r in rows), "a state outside the program in the log"
# program time runs from the start of the program in steps of the period
t = [float(r["program_time_s"]) for r in rows]
assert t[0] <= 1e-3 + 1e-9, f"the program time of the first state is {t[0]} s, expected at most one period"
assert all(abs((b - a) - 1e-3) < 1e-9 for a, b in zip(t, t[1:])), "program time not on the 1 ms grid"
from_log = sum(1 for _ in open(sys.argv[2])) - 1
from_tool = sum(1 for _ in open(sys.argv[3])) - 1
assert from_log == from_tool, f"experiments.lcm has {from_log} experiment rows, experiments.csv {from_tool}"
print(f"logs: evaluation-pgnn {len(rows)} consecutive cycles; experiments {from_log} rows in log and csv")
CHECK
) || fail "logs: $verdict"
echo "$verdict"

# --save: the configuration names the commissioned files, the old one is the
# backup, and a daemon started on it commutates with them.
cmp -s "$work/servod.yaml.bak" "$work/servod.before.yaml" || fail "--save: servod.yaml.bak is not the previous file"
outdir=$(cd "$out" && pwd -P)
# The law saved is the one the report recommends (pgnn, spline, spline-position or classical).
law=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["recommended"]["law"])' "$out/report.json") ||
    fail "report.json: no recommended law"
# The spline from positions runs in the spline law's slot.
mode=$law spline=model-spline.yaml
[ "$law" != spline-position ] || { mode=spline; spline=model-spline-position.yaml; }
check_saved "$mode" "  pgnn_model_file: \"$outdir/model-pgnn.yaml\"" "  calibration_file: \"$outdir/calibration.yaml\"" \
    "  spline_model_file: \"$outdir/$spline\"" "  feedforward_file: \"$outdir/feedforward-$law.yaml\"" "  mode: $mode"
[ "$(field pgnn_model_file "$saved_status" | cut -d' ' -f1)" = "$outdir/model-pgnn.yaml" ] ||
    fail "saved configuration: pgnn_model_file $(field pgnn_model_file "$saved_status")"
[ "$(field feedforward_file "$saved_status" | cut -d' ' -f1)" = "$outdir/feedforward-$law.yaml" ] ||
    fail "saved configuration: feedforward_file $(field feedforward_file "$saved_status")"
echo "clm commission --live --save: $elapsed s wall time; daemon exit 0 after SIGTERM; restarted on the saved configuration with the commissioned PGNN"
