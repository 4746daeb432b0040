#!/usr/bin/env bash
# The install rules and the Debian package (docs/packaging.md), label slow:
#   1. `cmake --install` into a staging directory (DESTDIR) with the
#      package's prefix /usr: every file where docs/packaging.md says, the
#      unit's ExecStart binary among them;
#   2. the staged clm-servod runs on the staged default configuration (the
#      embedded simulated motor; telemetry off) and exits 0;
#   3. the staged clm commissions on it with a short program and finds its
#      plotter in share/clm-servo beside bin/ (the PNGs are written);
#   4. cpack makes the .deb, and dpkg-deb lists the same files, a Depends
#      line from dpkg-shlibdeps, and every file under /etc as a conffile;
#   5. as root, the package's life in a root of its own (dpkg --root, the
#      maintainer scripts run with DPKG_ROOT): install; an edit of
#      /etc/clm-servo/servod.yaml survives an upgrade to a rebuilt package
#      with a higher version and a remove, and a purge removes it and the
#      key; /var/lib/clm-servo belongs to clm-operators; `man clm-servod`
#      shows the installed page.
# About 60 s.
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
  usr/lib/systemd/system/clm-servod.service usr/lib/systemd/system/clm-vcan0.service
  usr/share/man/man1/clm.1 usr/share/man/man1/clm-servod.1
  usr/bin/clm-spy usr/share/clm-servo/clm_lcmtypes.jar
  etc/clm-servo/servod.yaml etc/clm-servo/motor-sim.yaml etc/clm-servo/programs/fig8.yaml
  etc/clm-servo/programs/validation.yaml
  usr/share/clm-servo/plot_report.py usr/share/clm-servo/plot_capture.py
  usr/share/clm-servo/templates/servod-real.yaml usr/share/clm-servo/templates/motor-real.yaml
  usr/share/doc/clm-servo/docs/servod.md usr/share/doc/clm-servo/docs/bring-up.md usr/share/doc/clm-servo/README.md
  usr/share/doc/clm-servo/docs/images/tracking-error.png usr/share/doc/clm-servo/clm-servo.dbc
)
for file in "${expected[@]}"; do [ -f "$stage/$file" ] || fail "not installed: /$file"; done
for file in usr/bin/clm usr/bin/clm-servod usr/share/clm-servo/plot_report.py usr/share/clm-servo/plot_capture.py; do
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
    -e "s|^  file_directories: .*|  file_directories: [$etc, $stage/var/lib/clm-servo]|" \
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
[ -d "$stage/var/lib/clm-servo" ] || fail "/var/lib/clm-servo is not installed"
# The README's images where its links point.
grep -o '](docs/images/[^)]*)' "$stage/usr/share/doc/clm-servo/README.md" | sed 's/^](//; s/)$//' | while read -r image; do
  [ -f "$stage/usr/share/doc/clm-servo/$image" ] || fail "the installed README's image $image is missing"
done
# The packaged configuration allows the state directory, and loads.
grep -q "^  file_directories: \[/etc/clm-servo, /var/lib/clm-servo\]" "$etc/servod.yaml" ||
    fail "the packaged servod.yaml does not allow /var/lib/clm-servo: $(grep -A3 '^commands:' "$etc/servod.yaml")"
# The types jar holds the messages lcm-spy must decode.
for type in servo_state_t servo_status_t servo_event_t servo_command_t servo_command_ack_t; do
  /usr/bin/python3 -c "import sys, zipfile; sys.exit(0 if 'clm_lcm/$type.class' in zipfile.ZipFile(sys.argv[1]).namelist() else 1)" \
          "$stage/usr/share/clm-servo/clm_lcmtypes.jar" || fail "clm_lcmtypes.jar has no clm_lcm/$type.class"
done
dpkg-deb -e "$deb" "$work/control"
for file in servod.yaml motor-sim.yaml programs/fig8.yaml programs/validation.yaml; do
  grep -qx "/etc/clm-servo/$file" "$work/control/conffiles" || fail "/etc/clm-servo/$file is not a conffile"
done
echo "package: $(basename "$deb"), $(wc -l < "$work/contents.txt") entries, $(wc -l < "$work/control/conffiles") conffiles; Depends: $depends"

# ---- 5. install, upgrade, remove, purge --------------------------------------------------
if [ "$(id -u)" != 0 ]; then
  echo "lifecycle: not checked (dpkg --root needs root to give files their owners)"
  exit 0
fi
root="$work/root"
mkdir -p "$root/var/lib/dpkg/info" "$root/var/lib/dpkg/updates" "$root/etc"
touch "$root/var/lib/dpkg/status"
cp /etc/group /etc/passwd "$root/etc/"
[ -f /etc/gshadow ] && cp /etc/gshadow "$root/etc/"
sed -i '/^clm-operators:/d' "$root/etc/group" "$root/etc/gshadow" 2>/dev/null || true
dpkg_root() {  # dpkg in the scratch root: its scripts run outside a chroot with DPKG_ROOT set
  dpkg --root="$root" --log=/dev/null --force-script-chrootless --force-depends "$@" < /dev/null > "$work/dpkg.log" 2>&1 ||
      fail "dpkg $*: $(grep -v 'depends on\|is not installed\|dependency problems\|Package lib\|Package python' "$work/dpkg.log" | tail -3)"
}
dpkg_root -i "$deb"
config_file="$root/etc/clm-servo/servod.yaml"
[ -f "$config_file" ] && [ -f "$root/etc/clm-servo/command.key" ] || fail "install: no configuration or no key"
grep -q "^clm-operators:" "$root/etc/group" || fail "install: no group clm-operators"
# The group's name from the scratch root's own /etc/group: the id the package
# gave it there need not name a group (or the same one) on this host.
state_dir_owner() {
  local gid mode
  read -r gid mode < <(stat -c '%g %a' "$root/var/lib/clm-servo")
  echo "$(awk -F: -v gid="$gid" '$3 == gid { print $1; exit }' "$root/etc/group") $mode"
}
[ "$(state_dir_owner)" = "clm-operators 2775" ] ||
    fail "/var/lib/clm-servo is $(state_dir_owner) (group by $root/etc/group), expected clm-operators 2775"
sed -i 's/^  rate_hz: 1000\(.*\)/  rate_hz: 500\1  # edited/' "$config_file"
grep -q "rate_hz: 500 .*# edited" "$config_file" || fail "could not edit the installed servod.yaml"
cp "$config_file" "$work/edited.yaml"
cp "$root/etc/clm-servo/command.key" "$work/key"
# The same package rebuilt with a higher version.
dpkg-deb -R "$deb" "$work/rebuilt"
version=$(dpkg-deb -f "$deb" Version)
sed -i "s/^Version: .*/Version: ${version}+1/" "$work/rebuilt/DEBIAN/control"
dpkg-deb -b "$work/rebuilt" "$work/clm-servo-upgrade.deb" > /dev/null
dpkg_root -i "$work/clm-servo-upgrade.deb"
[ "$(dpkg-query --admindir="$root/var/lib/dpkg" -W -f '${Version}' clm-servo)" = "${version}+1" ] || fail "upgrade: not installed"
cmp -s "$config_file" "$work/edited.yaml" || fail "upgrade: the edited servod.yaml was not kept"
cmp -s "$root/etc/clm-servo/command.key" "$work/key" || fail "upgrade: the operators' key changed"
MANPATH="$root/usr/share/man" man -P cat clm-servod 2> "$work/man.err" | grep -q "clm-servod" ||
    fail "man clm-servod: $(head -1 "$work/man.err")"
dpkg_root -r clm-servo
[ ! -e "$root/usr/bin/clm-servod" ] || fail "remove: /usr/bin/clm-servod is still there"
cmp -s "$config_file" "$work/edited.yaml" || fail "remove: the edited servod.yaml was not kept"
dpkg_root -P clm-servo
[ ! -e "$config_file" ] || fail "purge: /etc/clm-servo/servod.yaml is still there"
[ ! -e "$root/etc/clm-servo/command.key" ] || fail "purge: the operators' key is still there"
echo "lifecycle: installed ${version}, an edit of servod.yaml kept by the upgrade to ${version}+1 and by remove," \
     "removed by purge with the key; /var/lib/clm-servo clm-operators 2775; man clm-servod"
