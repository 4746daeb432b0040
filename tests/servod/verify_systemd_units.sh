#!/usr/bin/env bash
# `systemd-analyze verify` on the units in systemd/ (label unit).
#
#   verify_systemd_units.sh SYSTEMD_ANALYZE UNIT_DIR UNIT...
#
# UNIT_DIR holds copies made by CMake with ExecStart pointing at the built
# clm-servod (verify refuses a unit whose binary does not exist). Other
# absolute executables that this machine lacks (modprobe without kmod, ip
# without iproute2) are replaced by /bin/true in a scratch copy, with a note:
# the test checks the units, not the build host's tools.
# Exit 77 (skipped) without systemd-analyze (Debian package `systemd`).
set -euo pipefail
analyze=$1 unit_dir=$2
shift 2
if [ -z "$analyze" ] || [ ! -x "$analyze" ]; then
  echo "systemd-analyze not found (Debian package systemd): skipped"
  exit 77
fi
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
for unit in "$@"; do
  cp "$unit_dir/$unit" "$scratch/$unit"
  for executable in $(sed -n 's/^Exec[A-Za-z]*=[-@:+!]*\(\/[^ ]*\).*/\1/p' "$scratch/$unit" | sort -u); do
    if [ ! -x "$executable" ]; then
      echo "note: $unit: $executable is not on this machine; verified with /bin/true in its place"
      sed -i "s#=\([-@:+!]*\)$executable\( \|\$\)#=\1/bin/true\2#" "$scratch/$unit"
    fi
  done
done
cd "$scratch"
# verify prints only problems; any output is a failure too.
output=$("$analyze" verify "$@" 2>&1) || { echo "$output"; exit 1; }
if [ -n "$output" ]; then
  echo "$output"
  exit 1
fi
echo "systemd-analyze verify: $* clean"
