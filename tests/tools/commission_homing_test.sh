#!/usr/bin/env bash
# `clm commission` (in process) on an axis that powers up at an encoder
# offset (docs/servod.md, "Homing"; docs/commissioning.md): the embedded
# default as shipped, whose encoder powers up at an offset (seed 9: −0.0497 m,
# beyond one pole pitch) and homes to the reference switch's edge
# (config/servod.yaml's homing:). Commissioning finds the commutation and
# homes before its experiments, completes, and records the reference:
# report.json's encoder_reference, and every calibration and model file's. clm calibrate on the same data records the
# reference given by --encoder-reference, none without it, and refuses an
# unknown method (exit 2, one line). About 15 s.
#
#   commission_homing_test.sh CLM SOURCE_DIR WORK_DIR
set -euo pipefail
clm=$1 source_dir=$2 work=$3
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"
fail() { echo "FAIL: $*" >&2; [ -f "$work/commission.log" ] && tail -n 20 "$work/commission.log" >&2; exit 1; }

rm -rf "$work"
mkdir -p "$work"
# The configuration as shipped, with its programs beside it.
cp -r "$source_dir/config" "$work/config"
config_require "$work/config/motor-sim.yaml" "    encoder_power_up_offset_max_m: 0.05" > /dev/null ||
    fail "config/motor-sim.yaml: the encoder is not the incremental one this test expects"
config_require "$work/config/servod.yaml" "  method: reference_switch" > /dev/null ||
    fail "config/servod.yaml: not the reference-switch homing this test expects"
reference_m=$(config_value "$work/config/servod.yaml" "  reference_position_m")

"$clm" commission --config "$work/config/servod.yaml" --program "$source_dir/tests/support/one_stroke_program.yaml" \
    --validation-program none --no-selection --out "$work/out" --no-plots > "$work/commission.log" 2>&1 ||
    fail "clm commission exited $?"
grep -q "\"encoder_reference\": {\"method\": \"reference_switch\", \"position_m\": $reference_m" "$work/out/report.json" ||
    fail "report.json: no encoder_reference reference_switch at $reference_m m: $(grep encoder_reference "$work/out/report.json")"
for file in calibration.yaml calibration-robust.yaml model-pgnn.yaml model-spline.yaml model-spline-position.yaml; do
  [ -f "$work/out/$file" ] || fail "$file not written"
  python3 - "$work/out/$file" "$reference_m" <<'PY' || fail "$file: its encoder_reference is not reference_switch at $reference_m m"
import sys
lines = open(sys.argv[1]).read().splitlines()
i = lines.index("encoder_reference:")
assert lines[i + 1].strip() == "method: reference_switch", lines[i + 1]
assert abs(float(lines[i + 2].split(":")[1]) - float(sys.argv[2])) < 1e-12, lines[i + 2]
PY
done
grep -q "^recommended for service: " "$work/commission.log" || fail "no recommendation"
# clm calibrate from the same data records the reference it is given, and none without one.
"$clm" calibrate --motor "$work/config/motor-sim.yaml" --data "$work/out/experiments.csv" --output "$work/given.yaml" \
    --encoder-reference reference_switch --reference-position-m -0.04 > /dev/null || fail "clm calibrate with a reference"
grep -A2 "^encoder_reference:" "$work/given.yaml" | grep -q "position_m: -0.04" || fail "clm calibrate: the reference given is not recorded"
"$clm" calibrate --motor "$work/config/motor-sim.yaml" --data "$work/out/experiments.csv" --output "$work/none.yaml" \
    > /dev/null || fail "clm calibrate without a reference"
grep -q "^encoder_reference:" "$work/none.yaml" && fail "clm calibrate without --encoder-reference wrote one"
rc=0
"$clm" calibrate --motor "$work/config/motor-sim.yaml" --data "$work/out/experiments.csv" --output "$work/bad.yaml" \
    --encoder-reference laser 2> "$work/bad.err" > /dev/null || rc=$?
[ "$rc" = 2 ] && [ "$(wc -l < "$work/bad.err")" = 1 ] && [ ! -e "$work/bad.yaml" ] ||
    fail "--encoder-reference laser: exit $rc, stderr '$(cat "$work/bad.err")'"
echo "commission_homing_test: passed"
