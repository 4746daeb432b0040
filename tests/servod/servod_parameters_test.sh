#!/usr/bin/env bash
# Process-level test of the run-time parameters through `clm ctl` (labels
# unit, lcm; docs/servod.md "Run-time parameters"): clm-servod on
# config/servod.yaml (the embedded simulated motor, real-time clock, no
# real-time rights) on an LCM port of its own.
#   - get lists every parameter with the configuration's values;
#   - set changes one, get reads it back, a move beyond a new limit is
#     refused naming it, a value outside the configuration's range is refused;
#   - status and watch show a move's end: position, velocity, following error;
#   - save writes the running values into the configuration file: the old
#     file is kept byte for byte as FILE.bak, the comments stay, and a second
#     daemon started on the saved file reports the set values;
#     without --config it writes the file the daemon was started from;
#   - save refuses a configuration of another axis, or of another motor
#     (servod-2coil.yaml), and leaves it unchanged.
# About 10 s.
#
#   servod_parameters_test.sh CLM_SERVOD CLM SOURCE_DIR WORK_DIR
set -euo pipefail
servod=$1 clm=$2 source_dir=$3 work=$4
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"

# A port of its own (10200..10249), apart from the other LCM tests.
port=$((10200 + $$ % 50))
url="udpm://239.255.76.67:${port}?ttl=0"
rm -rf "$work"
mkdir -p "$work"
trap cleanup_processes EXIT
fail() { fail_with_status "$*" "$work"/servod*.log; }

missing=$(loaded_host_motor "$source_dir/config/motor-sim.yaml" "$work/motor-sim.yaml" "${ABSOLUTE_MOTOR[@]}" &&
          config_edit "$source_dir/config/servod.yaml" "$work/servod.yaml" "${ABSOLUTE_CONFIG[@]}" \
          "motor_file: $work/motor-sim.yaml" "  priority: 0" "  lock_memory: false" "  clock: realtime" \
          "  lcm_url: \"$url\"" "  overrun_limit: 1000" && config_require "$work/servod.yaml" "  bandwidth_hz: 40.0" "  velocity_m_per_s: 0.5") ||
    fail "config: no line '$missing' after editing"
cp "$work/servod.yaml" "$work/servod.original.yaml"

start() {  # start LOG
  start_daemon "$work/servod.yaml" "$1"
  pid=$servod_pid
  local rc=0
  wait_for_status "$pid" 20 || rc=$?
  [ $rc != 2 ] || fail "clm-servod exited at start-up"
  [ $rc = 0 ] || fail "no status from clm-servod within 20 s"
}
start "$work/servod.log"

# Without --lcm-url, clm ctl takes the URL from $CLM_SERVO_LCM_URL.
CLM_SERVO_LCM_URL="$url" "$clm" ctl --timeout-s 5 status > /dev/null ||
    fail "clm ctl status with CLM_SERVO_LCM_URL and no --lcm-url did not find the daemon"

# get: every parameter, the configuration's values.
listing=$(ctl get) || fail "get refused"
[ "$(wc -l <<< "$listing")" = 15 ] || fail "get listed $(wc -l <<< "$listing") parameters, expected 15: $listing"
grep -qx "control.bandwidth_hz = 40 Hz" <<< "$listing" || fail "get: no 'control.bandwidth_hz = 40 Hz' in: $listing"
grep -qx "motion.velocity_m_per_s = 0.5 m/s" <<< "$listing" || fail "get: velocity not 0.5 m/s: $listing"

# set, get, and the new limit at work.
ctl set motion.velocity_m_per_s 0.3 > /dev/null || fail "set motion.velocity_m_per_s 0.3 refused"
ctl set control.bandwidth_hz 30 > /dev/null || fail "set control.bandwidth_hz 30 refused"
ctl set control.feedforward.coulomb_N 4.5 > /dev/null || fail "set control.feedforward.coulomb_N 4.5 refused"
[ "$(ctl get motion.velocity_m_per_s)" = "motion.velocity_m_per_s = 0.3 m/s" ] || fail "get after set: $(ctl get motion.velocity_m_per_s)"
ctl enable > /dev/null || fail "enable refused"
ctl_refused move-to --target-m 0.05 --velocity-m-per-s 0.4
[[ $reply == *"0.3"* ]] || fail "the refusal of a move at 0.4 m/s does not name the 0.3 m/s limit: $reply"
ctl_refused set control.force_limit_N 900
[ "$reply" = "rejected: control.force_limit_N: expected a number in [1, 819] N, got 900" ] || fail "refusal: $reply"

# status and watch show the axis's motion: a move to 0.02 m, then at rest there.
ctl move-to --target-m 0.02 --velocity-m-per-s 0.1 > /dev/null || fail "move-to 0.02 refused"
for _ in $(seq 50); do
  status=$(ctl status) || fail "status failed"
  grep -q "^program_running: false" <<< "$status" && break
  sleep 0.1
done
grep -q "^state: enabled" <<< "$status" || fail "status after the move: not enabled: $status"
awk '/^position_m: / { p = $2 } /^velocity_m_per_s: / { v = $2 } /^following_error_m: / { e = $2 }
     END { exit !(p > 0.02 - 1e-5 && p < 0.02 + 1e-5 && v > -1e-3 && v < 1e-3 && e > -1e-5 && e < 1e-5) }' <<< "$status" ||
    fail "status after the move to 0.02 m: position, velocity or following error off: $(grep -E '^(position|velocity|following|force)' <<< "$status")"
grep -q "^force_demand_N: " <<< "$status" || fail "status: no force_demand_N: $status"
watched=$(ctl watch --count 2 --every-s 0.1) || fail "watch failed"
[ "$(grep -c '^---$' <<< "$watched")" = 2 ] && [ "$(grep -c '^position_m: ' <<< "$watched")" = 2 ] ||
    fail "watch --count 2 did not print two statuses: $watched"
ctl disable > /dev/null || fail "disable refused"

# save: the values in the file, the comments kept, the old file as .bak.
ctl save --config "$work/servod.yaml" > "$work/save.out" || fail "save failed: $(cat "$work/save.out")"
cmp -s "$work/servod.yaml.bak" "$work/servod.original.yaml" || fail "servod.yaml.bak is not the previous file"
grep -q "^  velocity_m_per_s: 0.3 *# move-to and programs may not ask for more" "$work/servod.yaml" ||
    fail "saved file: no velocity 0.3 with its comment: $(grep velocity_m_per_s "$work/servod.yaml")"
grep -q "^  bandwidth_hz: 30 *# position-loop crossover" "$work/servod.yaml" || fail "saved file: no bandwidth 30"
grep -q "^  feedforward: {mass_kg: 0, viscous_N_s_per_m: 0, coulomb_N: 4.5}" "$work/servod.yaml" ||
    fail "saved file: feedforward: $(grep feedforward "$work/servod.yaml")"
# Only the three changed lines differ.
changed=$(diff "$work/servod.original.yaml" "$work/servod.yaml" | grep -c '^>' || true)
[ "$changed" = 3 ] || fail "save rewrote $changed lines: $(diff "$work/servod.original.yaml" "$work/servod.yaml")"
# Without --config: the file the daemon was started from (its signed status names it).
ctl save > "$work/save-again.out" || fail "a second save (no --config) failed"
grep -q "^$(realpath "$work/servod.yaml") already holds the running configuration" "$work/save-again.out" ||
    fail "a second save (no --config) did not name the daemon's file, or wrote again: $(cat "$work/save-again.out")"

# Another axis's configuration: refused, untouched.
sed 's/^  name: .*/  name: other-axis/' "$work/servod.original.yaml" > "$work/other.yaml"
grep -q "^  name: other-axis" "$work/other.yaml" || printf 'axis:\n  name: other-axis\n' >> "$work/other.yaml"
cp "$work/other.yaml" "$work/other.before.yaml"
if reply=$(ctl save --config "$work/other.yaml" 2>&1); then fail "save into another axis's file succeeded: $reply"; fi
[[ $reply == *"other-axis"* ]] || fail "save into another axis's file: $reply"
cmp -s "$work/other.yaml" "$work/other.before.yaml" || fail "another axis's file was changed"
[ ! -e "$work/other.yaml.bak" ] || fail "a backup of another axis's file was written"

# Another motor's configuration for the same axis name (the two-coil-set
# motor's, as shipped): refused, untouched.
sed "s|^motor_file: motor-sim-2coil.yaml|motor_file: $source_dir/config/motor-sim-2coil.yaml|" \
    "$source_dir/config/servod-2coil.yaml" > "$work/two-coil.yaml"
grep -q "^motor_file: $source_dir/config/motor-sim-2coil.yaml" "$work/two-coil.yaml" || fail "two-coil.yaml: no motor_file"
cp "$work/two-coil.yaml" "$work/two-coil.before.yaml"
if reply=$(ctl save --config "$work/two-coil.yaml" 2>&1); then fail "save into another motor's file succeeded: $reply"; fi
[[ $reply == *"motor-sim-2coil.yaml"*"is not the motor axis 'axis0' was started with"* ]] ||
    fail "save into another motor's file: $reply"
cmp -s "$work/two-coil.yaml" "$work/two-coil.before.yaml" || fail "another motor's file was changed"
[ ! -e "$work/two-coil.yaml.bak" ] || fail "a backup of another motor's file was written"

# A daemon started on the saved file runs with the saved values.
rc=0
stop_process "$pid" 10 || rc=$?
[ $rc = 0 ] || fail "clm-servod exit status $rc after SIGTERM"
start "$work/servod-2.log"
[ "$(ctl get motion.velocity_m_per_s)" = "motion.velocity_m_per_s = 0.3 m/s" ] || fail "restarted: $(ctl get motion.velocity_m_per_s)"
[ "$(ctl get control.bandwidth_hz)" = "control.bandwidth_hz = 30 Hz" ] || fail "restarted: $(ctl get control.bandwidth_hz)"
[ "$(ctl get control.feedforward.coulomb_N)" = "control.feedforward.coulomb_N = 4.5 N" ] || fail "restarted: coulomb"
rc=0
stop_process "$pid" 10 || rc=$?
[ $rc = 0 ] || fail "clm-servod exit status $rc after SIGTERM"
trap - EXIT
echo "clm ctl get/set/save: 3 parameters set, refused beyond their ranges, saved with comments and a backup (by default into the daemon's own file), refused for another axis and another motor, read back by a restarted daemon"
