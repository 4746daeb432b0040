#!/usr/bin/env bash
# The CTest entry of the HIL suite (label hil, docs/hil.md): natively where
# this kernel has vcan and we may use it, else in a QEMU guest.
#
#   hil_test.sh CLM CLM_SERVOD CHECKER SOURCE_DIR WORK_DIR
#
# HIL_SUITE picks the suite: fig8 (default; run_hil.sh, CHECKER is
# hil_candump_check) or faults (run_faults.sh, CHECKER is hil_fault_check,
# docs/reliability.md). HIL_MODE=native|qemu forces one. Exit status as run_hil.sh / run_qemu.sh
# (77: skipped, neither is possible here).
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
work=$5

native_possible() {
  # vcan needs SocketCAN in the kernel; the test that settles it is making one.
  [ -d /sys/class/net/vcan0 ] && return 0
  [ "$(id -u)" = 0 ] || return 1
  modprobe vcan 2> /dev/null
  ip link add dev vcanprobe$$ type vcan 2> /dev/null || return 1
  ip link del dev vcanprobe$$
}

suite=${HIL_SUITE:-fig8}
case $suite in
  fig8) script=run_hil.sh ;;
  faults) script=run_faults.sh ;;
  *) echo "HIL: HIL_SUITE must be fig8 or faults, got '$suite'"; exit 2 ;;
esac
mode=${HIL_MODE:-}
if [ -z "$mode" ]; then
  if native_possible; then mode=native; else mode=qemu; fi
fi
echo "HIL: suite $suite, mode $mode"
# Commissioning artefacts are reused while the clm that made them is unchanged
# (clm commission on the embedded default is deterministic); run_qemu.sh checks
# the same for its own directory.
if [ "$mode" = native ] && [ -z "${HIL_ARTIFACTS:-}" ] && [ -d "$work/native/commission" ] &&
   { [ ! -f "$work/native/commission/report.json" ] || [ "$1" -nt "$work/native/commission/report.json" ]; }; then
  rm -rf "$work/native/commission"
fi
if [ "$mode" = native ] && [ -z "${HIL_PC_ARTIFACTS:-}" ] && [ -d "$work/native/commission-phase-current" ] &&
   { [ ! -f "$work/native/commission-phase-current/report.json" ] ||
     [ "$1" -nt "$work/native/commission-phase-current/report.json" ]; }; then
  rm -rf "$work/native/commission-phase-current"
fi
case $mode in
  native) exec bash "$here/$script" "$1" "$2" "$3" "$4" "$work/native" ;;
  qemu) exec bash "$here/qemu/run_qemu.sh" "$1" "$2" "$3" "$4" "$work/qemu" ;;
  *) echo "HIL: HIL_MODE must be native or qemu, got '$mode'"; exit 2 ;;
esac
