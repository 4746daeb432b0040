#!/usr/bin/env bash
# `clm scope` against the real clm-servod process over LCM udpm (labels unit
# and lcm), on a port of its own, driven in a pseudo-terminal by
# scope_pty_check.py: a single-shot trigger on program_running catches a
# move's following error within 10 s of the scope's start, the screen shows
# every state of the exported window, and the same capture is made from an
# LCM log of that move. About 15 s, a minute on a loaded host.
#
#   scope_live_test.sh CLM_SERVOD CLM SOURCE_DIR WORK_DIR
set -euo pipefail
servod=$1 clm=$2 source_dir=$3 work=$4
# shellcheck source=../support/script_helpers.sh
source "$(dirname "${BASH_SOURCE[0]}")/../support/script_helpers.sh"

port=$((10400 + $$ % 40))
url="udpm://239.255.76.67:${port}?ttl=0"
rm -rf "$work"
mkdir -p "$work"
trap cleanup_processes EXIT
fail() { fail_with_status "$*" "$work/servod.log"; }

# A loaded host's settings (docs/bring-up.md, section 6): this tests the
# scope, not the loop's timing.
process_test_config "$work/servod.yaml"

start_daemon "$work/servod.yaml" "$work/servod.log"
rc=0
wait_for_status "$servod_pid" 20 || rc=$?
[ $rc = 0 ] || fail "clm-servod: no status within 20 s (rc $rc)"
reply=$(ctl enable) || fail "enable refused: $reply"

record_states "$work/move.lcm" "$work/logger.log"
wait_log_started "$work/move.lcm" 10 || fail "lcm-logger: no state within $waited_s s"

/usr/bin/python3 "$(dirname "$0")/scope_pty_check.py" "$clm" "$url" "$work" live || fail "clm scope live"
kill -INT "$logger_pid"
wait "$logger_pid" 2>/dev/null || true
/usr/bin/python3 "$(dirname "$0")/scope_pty_check.py" "$clm" "$url" "$work" log "$work/move.lcm" || fail "clm scope --log"
echo "PASS"
