#!/usr/bin/env bash
# The install rules and the Debian package (docs/packaging.md), label slow:
#   1. `cmake --install` into a staging directory (DESTDIR) with the
#      package's prefix /usr: every file where docs/packaging.md says, the
#      unit's ExecStart binary among them;
#   2. the staged clm-servod runs on the staged default configuration (the
#      embedded simulated motor; telemetry off) and exits 0;
#   3. the staged clm commissions on it with a short program and finds its
#      plotter in share/clm-servo beside bin/ (the PNGs are written);
#   4. cpack makes the .deb, and dpkg-deb lists the same files and a
#      Depends line from dpkg-shlibdeps.
# About 40 s.
#
#   package_test.sh BUILD_DIR WORK_DIR
set -euo pipefail
build=$1 work=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"
stage="$work/stage"

# ---- 1. the staged tree -----------------------------------------------------------
DESTDIR="$stage" cmake --install "$build" --prefix /usr > "$work/install.log" 2>&1 ||
    fail "cmake --install: $(tail -1 "$work/install.log")"
expected=(
  usr/bin/clm usr/bin/clm-servod
  usr/lib/systemd/system/clm-servod.service
  etc/clm-servo/servod.yaml etc/clm-servo/motor-sim.yaml etc/clm-servo/programs/fig8.yaml
  etc/clm-servo/programs/validation.yaml
  usr/share/clm-servo/plot_report.py
  usr/share/clm-servo/templates/servod-real.yaml usr/share/clm-servo/templates/motor-real.yaml
  usr/share/doc/clm-servo/servod.md usr/share/doc/clm-servo/bring-up.md usr/share/doc/clm-servo/README.md
  usr/share/doc/clm-servo/clm-servo.dbc
)
for file in "${expected[@]}"; do [ -f "$stage/$file" ] || fail "not installed: /$file"; done
for file in usr/bin/clm usr/bin/clm-servod usr/share/clm-servo/plot_report.py; do
  [ -x "$stage/$file" ] || fail "not executable: /$file"
done
unit="$stage/usr/lib/systemd/system/clm-servod.service"
exec_start=$(sed -n 's/^ExecStart=\([^ ]*\) .*/\1/p' "$unit")
[ -x "$stage$exec_start" ] || fail "the unit's ExecStart $exec_start is not among the installed files"
documentation=$(sed -n 's|^Documentation=file://||p' "$unit")
[ -f "$stage$documentation" ] || fail "the unit's Documentation $documentation is not installed"
config=$(sed -n 's/^ExecStart=[^ ]* --config \([^ ]*\)$/\1/p' "$unit")
[ -f "$stage$config" ] || fail "the unit's --config $config is not installed"
# Nothing of the source or build tree is baked into the binaries.
for binary in usr/bin/clm usr/bin/clm-servod; do
  if grep -qF "$(cd "$(dirname "$0")/../.." && pwd)" "$stage/$binary"; then fail "/$binary holds the source tree's path"; fi
done
echo "staged: ${#expected[@]} files where docs/packaging.md says; ExecStart $exec_start, --config $config"

# ---- 2. the daemon on the staged default configuration ------------------------------
etc="$stage/etc/clm-servo"
sed -e 's/^  enabled: true/  enabled: false/' -e 's/^  priority: 80/  priority: 0/' -e 's/^  lock_memory: true/  lock_memory: false/' \
    "$etc/servod.yaml" > "$etc/servod-test.yaml"
grep -q "^  enabled: false" "$etc/servod-test.yaml" || fail "could not switch telemetry off in the copy"
"$stage/usr/bin/clm-servod" --config "$etc/servod-test.yaml" --duration-s 1 > "$work/servod.out" 2> "$work/servod.err" ||
    fail "the staged clm-servod: $(tail -1 "$work/servod.err")"
grep -q "running: 1000 Hz" "$work/servod.err" || fail "the staged clm-servod did not run: $(head -1 "$work/servod.err")"
echo "staged clm-servod: $(grep "running:" "$work/servod.err")"

# ---- 3. the tools find their files through the installed layout -----------------------
cp "$(dirname "$0")/../support/one_stroke_program.yaml" "$etc/short.yaml"
"$stage/usr/bin/clm" commission --config "$etc/servod-test.yaml" --program "$etc/short.yaml" --validation-program none \
    --restarts 1 --out "$work/commission" > "$work/commission.out" 2> "$work/commission.err" ||
    fail "the staged clm commission: $(tail -1 "$work/commission.err")"
pngs=$(find "$work/commission" -name '*.png' | wc -l)
[ "$pngs" -ge 1 ] || fail "no plot written: the plotter was not found beside the staged clm"
echo "staged clm commission: report and $pngs plots"

# ---- 4. the package ------------------------------------------------------------------
(cd "$build" && cpack -G DEB -B "$work/package" > "$work/cpack.log" 2>&1) || fail "cpack: $(tail -3 "$work/cpack.log")"
deb=$(find "$work/package" -maxdepth 1 -name 'clm-servo_*.deb' | head -1)
[ -n "$deb" ] || fail "cpack wrote no clm-servo_*.deb"
dpkg-deb -c "$deb" | awk '{print $NF}' | sed 's|^\./|/|' > "$work/contents.txt"
for file in "${expected[@]}"; do
  grep -qx "/$file" "$work/contents.txt" || fail "not in the package: /$file"
done
depends=$(dpkg-deb -f "$deb" Depends)
for library in liblcm libyaml-cpp libstdc++6 python3-matplotlib; do
  [[ "$depends" == *"$library"* ]] || fail "Depends lacks $library: $depends"
done
echo "package: $(basename "$deb"), $(wc -l < "$work/contents.txt") entries; Depends: $depends"
