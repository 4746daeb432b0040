#!/usr/bin/env bash
# hil_fault_check on a hand-made candump log (testdata/faults.log, 60 cycles,
# L = 3) and event log: drive frames absent in cycles 10–12 with the setpoints
# zero from cycle 12 (3 cycles); an event whose defect is not on the bus
# (cycle 20); a drive frame 0.8 ms after its SYNC, after the RPDOs (cycle 30);
# the drive's fault bit in cycle 40 with zero setpoints only from cycle 41
# (2 cycles); two flood frames in cycle 50. The checker must see each of
# these, and not see what is not there.
#
#   fault_check_test.sh HIL_FAULT_CHECK TESTDATA_DIR
set -uo pipefail
checker=$1 data=$2
out=$("$checker" --log "$data/faults.log" --events "$data/faults-events.log" --coil-sets 3 --flood-id 6A0 --sim-killed)
rc=$?
echo "$out"
failed=0
expect() {
  if grep -qF -- "$1" <<< "$out"; then echo "PASS $1"; else echo "FAIL missing: $1"; failed=1; fi
}
[ $rc = 0 ] || { echo "FAIL exit status $rc"; failed=1; }
expect "cycles=60"
expect "step=1 kind=drop-drive frames=3 sync=10 seen_on_bus=1 enabled_before=1 max_setpoint_before_N=1.000 zero_after_cycles=3 enabled_after_cycles=2"
expect "step=2 kind=drop-drive frames=1 sync=20 seen_on_bus=0"
expect "step=3 kind=late-drive frames=1 sync=30 seen_on_bus=1 enabled_before=1"
expect "step=4 kind=drive-fault frames=1 sync=40 seen_on_bus=1 enabled_before=1 max_setpoint_before_N=1.000 zero_after_cycles=2 enabled_after_cycles=1"
expect "flood id=0x6A0 frames=2 "
expect "cycles_not_enabled=0"
expect "sim-killed first_cycle_without_feedback=61 enabled_before=1"
# A missing log is a usage error, not an empty result.
"$checker" --log "$data/no-such.log" > /dev/null 2>&1
[ $? = 2 ] && echo "PASS missing log: exit 2" || { echo "FAIL missing log: exit status not 2"; failed=1; }
exit $failed
