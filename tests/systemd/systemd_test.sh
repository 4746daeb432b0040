#!/usr/bin/env bash
# The systemd tier (docs/hil.md, "The systemd tier"): the Debian package under
# systemd as PID 1 in a QEMU guest. Makes the package of BUILD_DIR (cpack),
# the guest's Debian 12 root file system (build_rootfs.sh, cached), an
# initramfs (make_initramfs.sh), boots the HIL guest's kernel under TCG and
# reads the checks' lines (guest/checks.sh) from the serial console; the
# result is the line "SYSTEMD: N passed, M failed".
#
#   systemd_test.sh BUILD_DIR SOURCE_DIR WORK_DIR
#
# Environment (optional): CLM_SYSTEMD_CACHE_DIR (the root image's cache,
# default ${XDG_CACHE_HOME:-~/.cache}/clm-servo/systemd), CLM_SYSTEMD_MIRROR
# (build_rootfs.sh), SYSTEMD_QEMU_TIMEOUT_S (default 1200), SYSTEMD_KERNEL_VERSION
# (default: the newest /boot/vmlinuz-* with virtio_blk and ext4 modules),
# SYSTEMD_QEMU_DRIVE_OPTIONS (more -drive options, e.g. throttling.iops-total=20
# to see the guest on a slow host disk).
#
# Exit status: 0 every check passed; 1 a check failed, or the guest did not
# finish or gave no result; 77 this machine cannot run it (no QEMU, kernel,
# busybox-static, debootstrap, or not root for a cold build), with the reason.
set -uo pipefail
build=$1 source_dir=$2 work=$3
here=$(cd "$(dirname "$0")" && pwd)
timeout_s=${SYSTEMD_QEMU_TIMEOUT_S:-1200}
cache=${CLM_SYSTEMD_CACHE_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/clm-servo/systemd}
start_s=$(date +%s)

skip() { echo "SYSTEMD: skipped: $*"; exit 77; }
fail() { echo "SYSTEMD: 0 passed, 1 failed ($*)"; exit 1; }
qemu=$(command -v qemu-system-x86_64) || skip "no qemu-system-x86_64 (Debian package qemu-system-x86)"
command -v cpack > /dev/null || skip "no cpack (Debian package cmake)"
command -v dpkg-deb > /dev/null || skip "no dpkg-deb (Debian package dpkg)"
# shellcheck source=../hil/qemu/kernel_lib.sh
source "$source_dir/tests/hil/qemu/kernel_lib.sh"
kernel_version=${SYSTEMD_KERNEL_VERSION:-}
[ -n "$kernel_version" ] ||
    kernel_version=$(find_kernel_version kernel/drivers/block/virtio_blk.ko kernel/fs/ext4/ext4.ko) ||
    skip "no /boot/vmlinuz-* with virtio_blk and ext4 modules (Debian package linux-image-amd64)"
kernel=/boot/vmlinuz-$kernel_version
static_busybox=no
for candidate in /bin/busybox /usr/bin/busybox; do
  if [ -x "$candidate" ] && ! ldd "$candidate" > /dev/null 2>&1; then static_busybox=yes; fi
done
[ "$static_busybox" = yes ] || skip "no statically linked busybox (Debian package busybox-static)"

rm -rf "$work"
mkdir -p "$work"

# ---- the package of this build tree ---------------------------------------------------
(cd "$build" && cpack -G DEB -B "$work/package" > "$work/cpack.log" 2>&1) || { tail -3 "$work/cpack.log"; fail "cpack"; }
deb=$(find "$work/package" -maxdepth 1 -name 'clm-servo_*.deb' | head -1)
[ -n "$deb" ] || fail "cpack wrote no clm-servo_*.deb"
package_s=$(date +%s)
echo "SYSTEMD: package $(basename "$deb"); Depends: $(dpkg-deb -f "$deb" Depends)"

# ---- the root file system (cached) ----------------------------------------------------
rootfs_rc=0
bash "$here/build_rootfs.sh" "$deb" "$cache" > "$work/rootfs.out" 2>&1 || rootfs_rc=$?
grep -v "^/" "$work/rootfs.out"
[ "$rootfs_rc" = 77 ] && exit 77
[ "$rootfs_rc" = 0 ] || fail "the root file system"
image=$(tail -1 "$work/rootfs.out")
rootfs_s=$(date +%s)

# ---- initramfs and boot ----------------------------------------------------------------
bash "$here/make_initramfs.sh" "$work/initramfs.cpio.gz" "$work/initramfs" "$kernel_version" "$source_dir" "$deb" ||
    fail "the initramfs"
rm -rf "$work/initramfs"
echo "SYSTEMD: booting $kernel with $image (snapshot) under TCG (timeout $timeout_s s)"
boot_s=$(date +%s)
# As the HIL guest (tests/hil/qemu/run_qemu.sh): TCG with -icount
# shift=0,sleep=off, so that the guest's clocks follow its executed
# instructions and a busy host slows the run down without making the
# daemon's loop or its 0.5 s watchdog pings late; one vCPU. The root image
# is a snapshot: nothing is written back to the cache, and its writes (to a
# temporary overlay) need no flush (cache=unsafe). systemd prints only
# errors; no first-boot questions.
console=$work/console.log
timeout -k 10 "$timeout_s" "$qemu" -accel tcg -icount shift=0,sleep=off -m 1024 -smp 1 \
  -kernel "$kernel" -initrd "$work/initramfs.cpio.gz" \
  -append "console=ttyS0 quiet panic=-1 preempt=full systemd.show_status=error systemd.firstboot=off" \
  -drive "file=$image,format=raw,if=virtio,snapshot=on,cache=unsafe${SYSTEMD_QEMU_DRIVE_OPTIONS:+,$SYSTEMD_QEMU_DRIVE_OPTIONS}" \
  -nographic -no-reboot -net none < /dev/null 2>&1 | tr -d '\r' | tee "$console"
qemu_rc=${PIPESTATUS[0]}
end_s=$(date +%s)

result=$(grep -a -E "^SYSTEMD: [0-9]+ passed, [0-9]+ failed" "$console" | tail -1)
echo "SYSTEMD: host: package $((package_s - start_s)) s, root file system $((rootfs_s - package_s)) s," \
     "initramfs $((boot_s - rootfs_s)) s, guest $((end_s - boot_s)) s, total $((end_s - start_s)) s"
if [ -z "$result" ]; then
  if [ "$qemu_rc" = 124 ] || [ "$qemu_rc" = 137 ]; then
    echo "SYSTEMD: FAIL the guest did not finish within $timeout_s s (console: $console)"
  else
    echo "SYSTEMD: FAIL the guest gave no result line (qemu exit status $qemu_rc; console: $console)"
  fi
  exit 1
fi
failed=$(sed -n 's/^SYSTEMD: [0-9]* passed, \([0-9]*\) failed.*/\1/p' <<< "$result")
passed=$(sed -n 's/^SYSTEMD: \([0-9]*\) passed.*/\1/p' <<< "$result")
[ "$failed" = 0 ] && [ "$passed" -gt 0 ] && exit 0
exit 1
