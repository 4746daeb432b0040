#!/usr/bin/env bash
# The root file system of the systemd guest (docs/hil.md, "The systemd tier"):
# Debian 12 (bookworm) by debootstrap from Debian's packages, minbase with
# systemd as /sbin/init, iproute2 (the multicast route of LCM), liblcm-bin
# (lcm-logger, which the package recommends) and the runtime dependencies of
# the package DEB, read from its Depends (dpkg-deb -f) so that they never
# drift. The package itself is not installed here: the guest installs it
# (dpkg -i) at every run.
#
# The result is an ext4 image made by `mke2fs -d` (no loop mount), cached as
# CACHE_DIR/rootfs-KEY.ext4, KEY a hash of the suite, the mirror, the package
# list and this script; the guest boots it with QEMU's -snapshot, so it is
# never written. Images of other keys are removed. Prints the image's path
# as the last line.
#
#   build_rootfs.sh DEB CACHE_DIR
#
# Environment (optional): CLM_SYSTEMD_MIRROR (default http://deb.debian.org/debian).
# Exit status: 0 the image is there; 1 debootstrap or mke2fs failed; 77 this
# machine cannot build it (not root, no debootstrap or mke2fs, the mirror out
# of reach), with the reason.
set -euo pipefail
deb=$1 cache=$2
suite=bookworm
mirror=${CLM_SYSTEMD_MIRROR:-http://deb.debian.org/debian}
skip() { echo "SYSTEMD: skipped: $*"; exit 77; }
die() { echo "build_rootfs: $*" >&2; exit 1; }

[ -f "$deb" ] || die "no package $deb"
depends=$(dpkg-deb -f "$deb" Depends) || die "dpkg-deb -f $deb Depends failed"
# "libc6 (>= 2.34), python3 | python3-minimal, ..." -> libc6 python3 ...: the
# first alternative of each, without version or architecture qualifier.
package_names=$(tr ',' '\n' <<< "$depends" | sed -e 's/|.*//' -e 's/(.*)//' -e 's/:any//' -e 's/[[:space:]]//g' | sed '/^$/d')
packages=$( { printf '%s\n' systemd systemd-sysv iproute2 liblcm-bin; echo "$package_names"; } | sort -u | paste -sd, -)
key=$( { echo "$suite $mirror minbase $packages"; cat "$0"; } | sha256sum | cut -c1-16)
image=$cache/rootfs-$key.ext4
mkdir -p "$cache"
exec 9> "$cache/lock"
flock 9
if [ -f "$image" ]; then
  echo "build_rootfs: cached $image"
  echo "$image"
  exit 0
fi

[ "$(id -u)" = 0 ] || skip "building the guest's root file system needs root (debootstrap chroots); no cached image $image"
command -v debootstrap > /dev/null || skip "no debootstrap (Debian package debootstrap; .ci/install-deps.sh)"
command -v mke2fs > /dev/null || skip "no mke2fs (Debian package e2fsprogs)"

# Removes DIRECTORY, a debootstrap tree: whatever is still mounted in it
# (a failed debootstrap can leave proc, sys or a bind of /dev) is unmounted
# first, and rm never crosses into another file system.
remove_tree() {
  local directory mount_point
  directory=$(realpath -m "$1")
  [ -e "$directory" ] || return 0
  for mount_point in $(awk -v d="$directory/" 'index($2, d) == 1 { print $2 }' /proc/mounts | sort -r); do
    umount -l "$mount_point" || die "cannot unmount $mount_point"
  done
  rm -rf --one-file-system "$directory"
}

start_s=$(date +%s)
work=$cache/build-$key
root=$work/root
remove_tree "$work"
mkdir -p "$work"
echo "build_rootfs: debootstrap $suite from $mirror with $packages"
if ! debootstrap --variant=minbase --include="$packages" "$suite" "$root" "$mirror" > "$work/debootstrap.log" 2>&1; then
  tail -5 "$work/debootstrap.log" >&2
  # The mirror out of reach is this machine's limit, not the package's fault.
  if grep -q -E "Failed getting release file|Couldn't download|Unable to resolve|unable to resolve host" "$work/debootstrap.log"; then
    reason=$(grep -m1 -E "Failed getting release file|Couldn't download|resolve" "$work/debootstrap.log")
    remove_tree "$work"
    skip "debootstrap cannot reach $mirror: $reason"
  fi
  die "debootstrap failed (log: $work/debootstrap.log)"
fi
debootstrap_s=$(date +%s)

# A fixed identity, so that systemd does not treat every boot as the first.
od -An -N16 -tx1 /dev/urandom | tr -d ' \n' > "$root/etc/machine-id"
echo >> "$root/etc/machine-id"
echo clm-systemd-guest > "$root/etc/hostname"
# The package archives are not needed once unpacked.
rm -f "$root"/var/cache/apt/archives/*.deb "$root"/var/cache/apt/*.bin
rm -rf "$root"/var/lib/apt/lists/*

# An ext4 image of the tree, sparse, with room for the package and the test's files.
size_mb=$(( $(du -sm "$root" | cut -f1) * 3 / 2 + 512 ))
rm -f "$work/rootfs.ext4"
truncate -s "${size_mb}M" "$work/rootfs.ext4"
mke2fs -q -F -t ext4 -L clm-root -d "$root" "$work/rootfs.ext4" > "$work/mke2fs.log" 2>&1 ||
    die "mke2fs -d failed: $(tail -1 "$work/mke2fs.log")"
for old in "$cache"/rootfs-*.ext4; do [ -e "$old" ] && rm -f "$old"; done
mv "$work/rootfs.ext4" "$image"
remove_tree "$work"
end_s=$(date +%s)
echo "build_rootfs: built $image ($(du -h "$image" | cut -f1) used of ${size_mb} MB) in $((end_s - start_s)) s" \
     "(debootstrap $((debootstrap_s - start_s)) s, image $((end_s - debootstrap_s)) s)"
echo "$image"
