#!/usr/bin/env bash
# The HIL suite (tests/hil/run_hil.sh) in a QEMU guest, for hosts whose kernel
# has no SocketCAN (docs/hil.md). Boots the installed Debian kernel
# (linux-image-amd64) under TCG with an initramfs made here
# (make_initramfs.sh), reads the serial console and exits with the suite's
# result line "HIL: N passed, M failed".
#
#   run_qemu.sh CLM CLM_SERVOD HIL_CANDUMP_CHECK SOURCE_DIR WORK_DIR
#
# Environment (optional): HIL_SUITE (fig8, default, or faults: run_faults.sh,
# which needs no commissioning), HIL_QEMU_TIMEOUT_S (default 1500), HIL_KERNEL_VERSION
# (default: the newest /boot/vmlinuz-* whose modules include vcan), and the
# HIL_* variables of run_hil.sh, which are handed to the guest.
#
# Exit status: 0 all passed; 1 a check failed, the guest did not finish or
# gave no result; 77 no usable kernel or QEMU here (skipped).
set -uo pipefail
clm=$1 servod=$2 checker=$3 source_dir=$4 work=$5
suite=${HIL_SUITE:-fig8}
# The fig8 suite's files keep their names; the fault suite's carry its name.
suffix=""
[ "$suite" = fig8 ] || suffix=-$suite
here=$(cd "$(dirname "$0")" && pwd)
timeout_s=${HIL_QEMU_TIMEOUT_S:-1500}
start_s=$(date +%s)

skip() { echo "HIL: skipped: $*"; exit 77; }
qemu=$(command -v qemu-system-x86_64) || skip "no qemu-system-x86_64 (Debian package qemu-system-x86)"

# A kernel with the vcan module on disk and a readable image.
# shellcheck source=kernel_lib.sh
source "$here/kernel_lib.sh"
kernel_version=${HIL_KERNEL_VERSION:-}
[ -n "$kernel_version" ] || kernel_version=$(find_kernel_version kernel/drivers/net/can/vcan.ko) || true
[ -n "$kernel_version" ] || skip "no /boot/vmlinuz-* with a vcan module (Debian package linux-image-amd64)"
kernel=/boot/vmlinuz-$kernel_version

mkdir -p "$work"

# Commissioning artefacts, made on the host (fast) and reused while the clm
# that made them is unchanged: clm commission on the embedded default is
# deterministic.
artifacts=${HIL_ARTIFACTS:-$work/commission}
if [ "$suite" = fig8 ] && { [ ! -f "$artifacts/report.json" ] || [ "$clm" -nt "$artifacts/report.json" ]; }; then
  echo "HIL: commissioning the embedded default on the host into $artifacts"
  commission_start=$(date +%s)
  if ! "$clm" commission --config "$source_dir/config/servod.yaml" --out "$artifacts" --no-plots > "$work/commission.log" 2>&1; then
    tail -5 "$work/commission.log"
    echo "HIL: 0 passed, 1 failed (clm commission on the host)"
    exit 1
  fi
  echo "HIL: commissioning took $(( $(date +%s) - commission_start )) s"
fi
# The same for the phase-current drive (run_hil.sh's phase_current_suite):
# the one-stroke program, no held-out run.
pc_artifacts=${HIL_PC_ARTIFACTS:-$work/commission-phase-current}
if [ "$suite" = fig8 ] && { [ ! -f "$pc_artifacts/report.json" ] || [ "$clm" -nt "$pc_artifacts/report.json" ]; }; then
  echo "HIL: commissioning the phase-current drive on the host into $pc_artifacts"
  commission_start=$(date +%s)
  if ! "$clm" commission --config "$source_dir/config/servod-phase-current.yaml" \
       --program "$source_dir/tests/support/one_stroke_program.yaml" \
       --experiment-program "$source_dir/tests/support/one_stroke_program.yaml" --validation-program none \
       --out "$pc_artifacts" --no-plots > "$work/commission-phase-current.log" 2>&1; then
    tail -5 "$work/commission-phase-current.log"
    echo "HIL: 0 passed, 1 failed (clm commission of the phase-current drive on the host)"
    exit 1
  fi
  echo "HIL: phase-current commissioning took $(( $(date +%s) - commission_start )) s"
fi
initramfs_start=$(date +%s)

# What the guest's /init exports before it runs the suite.
{
  printf "HIL_SUITE='%s'\n" "$suite"
  for variable in HIL_MODES HIL_PROGRAM HIL_MAX_E_M_classical HIL_MAX_E_M_pgnn HIL_PRIORITY HIL_PC_MAX_E_M_classical \
                  HIL_PC_MAX_E_M_pgnn; do
    [ -n "${!variable:-}" ] && printf "%s='%s'\n" "$variable" "${!variable}"
  done
  true
} > "$work/guest$suffix.env"

initramfs=$work/initramfs$suffix.cpio.gz
if ! PC_ARTIFACTS=$pc_artifacts bash "$here/make_initramfs.sh" "$initramfs" "$work/initramfs$suffix" "$kernel_version" "$source_dir" "$artifacts" \
       "$work/guest$suffix.env" "$clm" "$servod" "$checker"; then
  echo "HIL: 0 passed, 1 failed (initramfs)"
  exit 1
fi
rm -rf "$work/initramfs$suffix"
echo "HIL: booting $kernel under TCG (timeout $timeout_s s)"
boot_s=$(date +%s)

# TCG (this host may have no usable KVM) with -icount shift=0,sleep=off: the
# guest's clocks advance by 1 ns per executed instruction and jump over idle
# time, so a loaded or slow host slows the run down in wall-clock time but
# never makes the guest's 1 kHz loop late (docs/hil.md, "Guest time"). One
# vCPU: with icount and sleep=off the kernel hangs bringing up a second one.
# preempt=full (Debian's kernel is PREEMPT_DYNAMIC): on one vCPU, a process
# starting up must not hold the kernel for a millisecond against the loop.
# The guest powers off at the end; a panic or a hang ends by panic=-1 with
# -no-reboot, or by the timeout.
console=$work/console$suffix.log
timeout -k 10 "$timeout_s" "$qemu" -accel tcg -icount shift=0,sleep=off -m 2048 -smp 1 \
  -kernel "$kernel" -initrd "$initramfs" -append "console=ttyS0 quiet panic=-1 preempt=full" \
  -nographic -no-reboot -net none < /dev/null 2>&1 | tr -d '\r' | tee "$console"
qemu_rc=${PIPESTATUS[0]}
end_s=$(date +%s)

result=$(grep -a -E "^HIL: [0-9]+ passed, [0-9]+ failed" "$console" | tail -1)
echo "HIL: host: commissioning $(( initramfs_start - start_s )) s, initramfs $(( boot_s - initramfs_start )) s," \
     "guest $(( end_s - boot_s )) s, total $(( end_s - start_s )) s"
if [ -z "$result" ]; then
  if [ "$qemu_rc" = 124 ] || [ "$qemu_rc" = 137 ]; then
    echo "HIL: FAIL the guest did not finish within $timeout_s s"
  else
    echo "HIL: FAIL the guest gave no result line (qemu exit status $qemu_rc; console: $console)"
  fi
  exit 1
fi
failed=$(sed -n 's/^HIL: [0-9]* passed, \([0-9]*\) failed.*/\1/p' <<< "$result")
passed=$(sed -n 's/^HIL: \([0-9]*\) passed.*/\1/p' <<< "$result")
[ "$failed" = 0 ] && [ "$passed" -gt 0 ] && exit 0
exit 1
