#!/usr/bin/env bash
# Builds the initramfs of the HIL guest (docs/hil.md): busybox-static, bash,
# the CAN kernel modules of the installed Debian kernel and their
# dependencies, candump, cangen, lcm-logger, the clm-servo programs with every shared
# library ldd names, the configuration the suite reads, the commissioning
# artefacts and /init (tests/hil/qemu/init). Written under the build
# directory at test time; nothing of it is committed.
#
#   make_initramfs.sh OUT.cpio.gz STAGING_DIR KERNEL_VERSION SOURCE_DIR ARTIFACTS_DIR GUEST_ENV CLM CLM_SERVOD HIL_CANDUMP_CHECK
#
# GUEST_ENV is a file of VAR=value lines the guest's /init exports before it
# runs the suite (HIL_MODES, HIL_PROGRAM, ...). Exits non-zero with one line
# naming what is missing.
set -euo pipefail
out=$1 staging=$2 kernel_version=$3 source_dir=$4 artifacts=$5 guest_env=$6
shift 6
programs=("$@")  # clm clm-servod hil_candump_check or hil_fault_check

die() { echo "make_initramfs: $*" >&2; exit 1; }

modules_dir=/lib/modules/$kernel_version
[ -d "$modules_dir" ] || die "no $modules_dir (install the Debian package linux-image-amd64)"

# A statically linked busybox (busybox-static): the guest has no libc of its own
# before the libraries below are in place, and /init runs on it.
busybox=""
for candidate in /bin/busybox /usr/bin/busybox; do
  if [ -x "$candidate" ] && ! ldd "$candidate" > /dev/null 2>&1; then busybox=$candidate; break; fi
done
[ -n "$busybox" ] || die "no statically linked busybox (install busybox-static)"
for tool in bash awk candump cangen lcm-logger; do
  command -v "$tool" > /dev/null || die "no $tool on this host (packages: bash, mawk, can-utils, liblcm-bin)"
done

rm -rf "$staging"
mkdir -p "$staging"/{bin,sbin,usr/bin,usr/sbin,lib,lib64,proc,sys,dev,tmp,run,etc,root,hil/bin,hil/modules,hil/artifacts}

# busybox and its applets, as links; bash and the programs below take precedence.
cp "$busybox" "$staging/bin/busybox"
for applet in $("$busybox" --list); do
  [ "$applet" = busybox ] && continue
  ln -s /bin/busybox "$staging/bin/$applet"
done
ln -sf /bin/busybox "$staging/usr/bin/env"

# A program and every shared library it loads, at the paths ldd reports (the
# dynamic loader included), so the guest resolves them as the host does.
copy_libraries() {
  local binary=$1
  ldd "$binary" | awk '/=> \// { print $3 } /^[[:space:]]*\// { print $1 }' | while read -r library; do
    [ -e "$staging$library" ] && continue
    mkdir -p "$staging$(dirname "$library")"
    cp -L "$library" "$staging$library"
  done
}
install_program() {
  local binary=$1 destination=$2
  rm -f "$staging$destination"
  cp -L "$binary" "$staging$destination"
  copy_libraries "$binary"
}
install_program "$(command -v bash)" /bin/bash
# The suite's awk needs sqrt, which Debian's busybox awk lacks: the host's awk (mawk or gawk).
install_program "$(readlink -f "$(command -v awk)")" /bin/awk
install_program "$(command -v candump)" /usr/bin/candump
install_program "$(command -v cangen)" /usr/bin/cangen
install_program "$(command -v lcm-logger)" /usr/bin/lcm-logger
# util-linux's chrt: the simulated motor gets SCHED_FIFO like the daemon's loop.
command -v chrt > /dev/null && install_program "$(command -v chrt)" /usr/bin/chrt
for program in "${programs[@]}"; do
  [ -x "$program" ] || die "no program $program (build it first)"
  install_program "$program" "/hil/bin/$(basename "$program")"
done

# The CAN modules and what they depend on (modinfo's depends:), in load
# order, decompressed if the kernel package ships them compressed.
# shellcheck source=kernel_lib.sh
source "$(dirname "$0")/kernel_lib.sh"
copy_kernel_modules "$kernel_version" "$staging/hil/modules" can can-raw can-dev vcan 2> "$staging.modules.err" ||
    die "$(cat "$staging.modules.err")"
rm -f "$staging.modules.err"
mapfile -t order < "$staging/hil/modules/order"

# What the suite reads from the source tree, at the same relative paths.
for file in config/servod-vcan.yaml config/motor-sim.yaml drivers/can/clm-servo.dbc tests/hil/run_hil.sh \
            tests/hil/run_faults.sh tests/support/script_helpers.sh config/motor-sim-phase-current.yaml \
            config/servod-phase-current.yaml drivers/can/clm-servo-phase-current.dbc \
            tests/support/one_stroke_program.yaml; do
  mkdir -p "$staging/hil/src/$(dirname "$file")"
  cp "$source_dir/$file" "$staging/hil/src/$file"
done
mkdir -p "$staging/hil/src/config/programs"
cp "$source_dir"/config/programs/*.yaml "$staging/hil/src/config/programs/"
# The commissioning artefacts, for the Fig. 8 suite (the fault suite runs the
# drive's original commutation and needs none).
if grep -q "^HIL_SUITE='faults'" "$guest_env"; then
  :
else
  for file in calibration.yaml model-pgnn.yaml feedforward-classical.yaml feedforward-pgnn.yaml; do
    [ -f "$artifacts/$file" ] || die "no $artifacts/$file (clm commission --out $artifacts)"
  done
  cp "$artifacts"/calibration.yaml "$artifacts"/model-*.yaml "$artifacts"/feedforward-*.yaml "$staging/hil/artifacts/"
  # The phase-current drive's (PC_ARTIFACTS in the environment, run_qemu.sh).
  for file in calibration.yaml model-pgnn.yaml feedforward-classical.yaml feedforward-pgnn.yaml; do
    [ -f "${PC_ARTIFACTS:-}/$file" ] || die "no ${PC_ARTIFACTS:-(PC_ARTIFACTS unset)}/$file (clm commission --out DIR)"
  done
  mkdir -p "$staging/hil/artifacts-phase-current"
  cp "$PC_ARTIFACTS"/calibration.yaml "$PC_ARTIFACTS"/model-*.yaml "$PC_ARTIFACTS"/feedforward-*.yaml \
     "$staging/hil/artifacts-phase-current/"
fi
cp "$guest_env" "$staging/hil/env"
cp "$source_dir/tests/hil/qemu/init" "$staging/init"
chmod 755 "$staging/init"
echo "root:x:0:0:root:/root:/bin/sh" > "$staging/etc/passwd"

# newc cpio, gzip -1: the guest decompresses it under TCG, where speed matters more than size.
(cd "$staging" && find . -print | sort | "$busybox" cpio -o -H newc 2> /dev/null) | gzip -1 > "$out.tmp"
mv "$out.tmp" "$out"
echo "make_initramfs: $out ($(du -h "$out" | cut -f1)), kernel $kernel_version, modules ${order[*]}"
