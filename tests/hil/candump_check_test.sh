#!/usr/bin/env bash
# hil_candump_check on hand-made candump -L logs (label unit): a log of good
# frames of every message passes; in a log of bad lines each one is reported
# with its line number and the reason, and the exit status is 1; for an axis
# without a force sensor a force frame is reported and the rest passes.
#
#   candump_check_test.sh HIL_CANDUMP_CHECK DBC TESTDATA_DIR [PHASE_CURRENT_DBC]
#
# With PHASE_CURRENT_DBC: the same good log passes as a phase-current drive's
# bus (same identifiers and DLCs; the RPDOs read as i_a, i_b), and a DBC that
# does not match the frames (an RPDO signal cut short) fails.
set -uo pipefail
checker=$1 dbc=$2 data=$3 pc_dbc=${4:-}
fail() { echo "FAIL: $*"; exit 1; }

out=$("$checker" --dbc "$dbc" --log "$data/good.log" --coil-sets 3)
rc=$?
echo "$out"
[ $rc = 0 ] || fail "good.log: exit status $rc"
grep -q "all 6 frames" <<< "$out" || fail "good.log: not 'all 6 frames'"
grep -q "DriveFeedback 1, DriveSetpoint1 1, DriveSetpoint2 1, ForceFeedback 1, Sync 2" <<< "$out" || fail "good.log: counts"

out=$("$checker" --dbc "$dbc" --log "$data/bad.log" --coil-sets 3)
rc=$?
echo "$out"
[ $rc = 1 ] || fail "bad.log: exit status $rc, expected 1"
for expected in \
  "bad.log:2: Sync.SyncCounter: raw 0 outside the DBC's \[1, 240\]" \
  "bad.log:3: DriveFeedback.StatusReserved: raw 1 outside the DBC's \[0, 0\]" \
  "bad.log:4: DriveSetpoint1: DLC 2, the DBC says 6" \
  "bad.log:5: no message with identifier 0x123 in the DBC" \
  "bad.log:6: error frame (CAN_ERR_FLAG)" \
  "bad.log:7: DriveSetpoint3: the codec refuses it (wrong id)" \
  "bad.log:8: not a candump -L frame line" \
  "bad.log:9: candump lost frames: DROPCOUNT" \
  "FAIL: 8 of 10 lines"; do
  grep -q "$expected" <<< "$out" || fail "bad.log: no line matching '$expected'"
done
if "$checker" --dbc "$dbc" --log /nonexistent 2> /dev/null; then fail "a missing log passed"; fi
# An axis without a force sensor: its force frame does not belong on the bus,
# the same log without it passes.
out=$("$checker" --dbc "$dbc" --log "$data/good.log" --coil-sets 3 --force-sensor-node-id 0)
rc=$?
[ $rc = 1 ] || fail "good.log without a force sensor: exit status $rc, expected 1 ($out)"
grep -q "ForceFeedback: the codec refuses it" <<< "$out" || fail "good.log without a force sensor: $out"
tmp=$(mktemp -d)
grep -v " 182#" "$data/good.log" > "$tmp/no-force.log"
out=$("$checker" --dbc "$dbc" --log "$tmp/no-force.log" --coil-sets 3 --force-sensor-node-id 0)
rc=$?
rm -rf "$tmp"
[ $rc = 0 ] || fail "good.log without its force frame, no force sensor: exit status $rc ($out)"
grep -q "DriveFeedback 1, DriveSetpoint1 1, DriveSetpoint2 1, Sync 2" <<< "$out" || fail "no force sensor: counts ($out)"
if [ -n "$pc_dbc" ]; then
  out=$("$checker" --dbc "$pc_dbc" --drive-profile phase_current --log "$data/good.log" --coil-sets 3)
  rc=$?
  echo "$out"
  [ $rc = 0 ] || fail "good.log as phase_current: exit status $rc"
  grep -q "DriveFeedback 1, DriveSetpoint1 1, DriveSetpoint2 1, ForceFeedback 1, Sync 2" <<< "$out" ||
    fail "good.log as phase_current: counts"
  if "$checker" --dbc "$pc_dbc" --drive-profile both --log "$data/good.log" 2> /dev/null; then
    fail "--drive-profile both was accepted"
  fi
  # A phase-current DBC whose Ib1_A covers 8 bits instead of 16 leaves bits uncovered.
  tmp=$(mktemp -d)
  sed 's/ SG_ Ib1_A : 32|16@1-/ SG_ Ib1_A : 32|8@1-/' "$pc_dbc" > "$tmp/short.dbc"
  out=$("$checker" --dbc "$tmp/short.dbc" --drive-profile phase_current --log "$data/good.log" --coil-sets 3)
  rc=$?
  rm -rf "$tmp"
  [ $rc = 1 ] || fail "a phase-current DBC with Ib1_A cut short: exit status $rc, expected 1 ($out)"
fi
echo "hil_candump_check: good and bad logs judged as expected"
