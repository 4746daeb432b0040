#!/usr/bin/env bash
# Process-level test of homing (labels unit, lcm; docs/servod.md "Homing"):
# clm-servod on the embedded simulated motor with an incremental encoder
# that powers up at an offset (seed 9: −0.0497 m, beyond one pole pitch) and
# index marks every 10 mm, on the real-time clock and an LCM port of its own.
# Through clm ctl and the daemon's signed status:
#   - at start: `homing: idle, commutation unknown, not homed`; a
#     position-dependent law refused with the not-homed reason;
#   - `clm ctl enable` finds the commutation (`commutation found, not
#     homed`); move-to is refused with the not-homed reason;
#   - `clm ctl home`: the status reaches `commutation found, homed`
#     with the found phase and the axis offset, the axis enabled, no fault;
#   - then move-to is accepted and the move ends.
#
#   servod_homing_test.sh CLM_SERVOD CLM SOURCE_DIR WORK_DIR
set -euo pipefail
servod=$1 clm=$2 source_dir=$3 work=$4
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"

url="udpm://239.255.76.67:$((9800 + $$ % 50))?ttl=0"
rm -rf "$work"
mkdir -p "$work"
trap cleanup_processes EXIT
fail() { fail_with_status "$*" "$work/servod.log"; }

process_test_config "$work/servod.yaml" "  lock_memory: false"
# The incremental encoder: its sensor keys after the noise seed (docs/simulator.md).
sed -i 's|^    noise_seed: 2$|    noise_seed: 2\n    encoder_power_up_offset_max_m: 0.05\n    encoder_offset_seed: 9\n    index_pitch_m: 0.01|' \
    "$work/motor-sim.yaml"
config_require "$work/motor-sim.yaml" "    index_pitch_m: 0.01" > /dev/null || fail "motor: the encoder keys were not added"
grep -q "^homing:" "$work/servod.yaml" && fail "config/servod.yaml has a homing: section; edit it instead"
printf 'homing:\n  method: index\n  direction: 1\n  search_velocity_m_per_s: 0.01\n  search_distance_m: 0.02\n' >> "$work/servod.yaml"

start_daemon "$work/servod.yaml" "$work/servod.log"
rc=0
wait_for_status "$servod_pid" 20 || rc=$?
[ $rc != 2 ] || fail "clm-servod exited at start-up"
[ $rc = 0 ] || fail "no status from clm-servod within 20 s"
[ "$(field homing "$status")" = "idle, commutation unknown, not homed (positions are the encoder's reading)" ] ||
    fail "status at start: homing '$(field homing "$status")'"

ctl_refused commutation classical
[[ $reply == *"not homed"* ]] || fail "commutation classical before homing: refused with '$reply', not for homing"

# Until `homing` starts with PREFIX (or a fault, or 30 s): sets `status` and `homed`.
wait_homing() {
  homed=""
  for _ in $(seq 1 60); do
    status=$(ctl status --timeout-s 1 2> /dev/null) || continue
    [ "$(field state "$status")" = fault ] && fail "a fault while waiting for homing '$1'"
    homed=$(field homing "$status")
    [[ $homed == "$1"* ]] && return 0
    sleep 0.5
  done
  fail "homing not '$1' within 30 s: '$homed'"
}
# enable finds the commutation; a move to a position is still refused.
ctl enable > /dev/null || fail "enable refused"
wait_homing "idle, commutation found, not homed"
ctl_refused move-to --target-m 0.001 --velocity-m-per-s 0.01
[[ $reply == *"not homed"* ]] || fail "move-to before homing: refused with '$reply', not for homing"

ctl home > /dev/null || fail "home refused"
wait_homing "idle, commutation found, homed"
[[ $homed == "idle, commutation found, homed, found phase "*", axis offset "*" m" ]] ||
    fail "not homed within 30 s: homing '$homed'"
[ "$(field state "$status")" = enabled ] || fail "state after home: '$(field state "$status")', expected enabled"

position=$(field position_m "$status")
ctl move-to --target-m "$(awk -v p="$position" 'BEGIN { printf "%.6f", p + 0.002 }')" --velocity-m-per-s 0.01 \
    > /dev/null || fail "move-to after homing refused"
ctl status > /dev/null
echo "servod_homing_test: passed (homing: $homed)"
