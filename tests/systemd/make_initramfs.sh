#!/usr/bin/env bash
# The initramfs of the systemd guest (docs/hil.md, "The systemd tier"): a
# statically linked busybox; the modules of the installed Debian kernel that
# mount the root file system (virtio block device, ext4) with their
# dependencies, and autofs4 and binfmt_misc, which systemd mounts at boot
# (the root image has no modules of its own); /init (tests/systemd/init);
# and under /payload what the guest needs for this run: the package, the
# checks and their units. /init mounts the root image, copies the payload
# into it and hands over to systemd. Written under the build directory at
# test time; nothing of it is committed.
#
#   make_initramfs.sh OUT.cpio.gz STAGING_DIR KERNEL_VERSION SOURCE_DIR DEB
#
# Exits non-zero with one line naming what is missing.
set -euo pipefail
out=$1 staging=$2 kernel_version=$3 source_dir=$4 deb=$5
die() { echo "make_initramfs: $*" >&2; exit 1; }
# shellcheck source=../hil/qemu/kernel_lib.sh
source "$source_dir/tests/hil/qemu/kernel_lib.sh"

busybox=""
for candidate in /bin/busybox /usr/bin/busybox; do
  if [ -x "$candidate" ] && ! ldd "$candidate" > /dev/null 2>&1; then busybox=$candidate; break; fi
done
[ -n "$busybox" ] || die "no statically linked busybox (install busybox-static)"
[ -f "$deb" ] || die "no package $deb"

rm -rf "$staging"
mkdir -p "$staging"/{bin,proc,sys,dev,newroot,payload/units}
cp "$busybox" "$staging/bin/busybox"
for applet in $("$busybox" --list); do
  [ "$applet" = busybox ] || ln -s busybox "$staging/bin/$applet"
done
copy_kernel_modules "$kernel_version" "$staging/modules" virtio_pci virtio_blk crc32c_generic ext4 autofs4 binfmt_misc \
    2> "$staging.modules.err" || die "$(cat "$staging.modules.err")"
rm -f "$staging.modules.err"

cp "$deb" "$staging/payload/clm-servo.deb"
cp "$source_dir/tests/systemd/guest/checks.sh" "$staging/payload/checks.sh"
cp "$source_dir"/tests/systemd/guest/*.service "$source_dir"/tests/systemd/guest/*.conf "$staging/payload/units/"
cp "$source_dir/tests/systemd/init" "$staging/init"
chmod 755 "$staging/init" "$staging/payload/checks.sh"

(cd "$staging" && find . -print | sort | "$busybox" cpio -o -H newc 2> /dev/null) | gzip -1 > "$out.tmp"
mv "$out.tmp" "$out"
echo "make_initramfs: $out ($(du -h "$out" | cut -f1)), kernel $kernel_version, modules $(tr '\n' ' ' < "$staging/modules/order")"
