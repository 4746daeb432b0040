#!/bin/bash
# The checks of the systemd guest (docs/hil.md, "The systemd tier"), run by
# clm-systemd-checks.service as root once the guest has booted (systemd is
# PID 1). Installs the package with dpkg -i, then checks clm-servod as
# systemd runs it from the package's unit:
#   installed           dpkg -i; systemd knows the unit from the package
#   ready               `systemctl start` returns once READY=1: active (running)
#   watchdog_pings      WatchdogTimestampMonotonic advances (WATCHDOG=1 arrives)
#   sandbox_realtime    the unit's limits and hardening let the daemon work:
#                       a dynamic user, memory locked (mlockall), the loop
#                       thread SCHED_FIFO at loop.priority, its StateDirectory
#                       owned by that user, no warning in its journal
#   stop_disables_axis  enabled by `clm ctl enable` over LCM, `systemctl stop`:
#                       the daemon's own CLM_SERVO_STATE (lcm-logger) shows the
#                       axis disabled before the process exited, the journal
#                       "axis disabled" before "exiting", exit status 0
#   watchdog_restart    SIGSTOP (a hung loop): systemd kills and restarts it
#                       after WatchdogSec (NRestarts +1, a new MainPID, active)
#   config_error_no_restart  a broken /etc/clm-servo/servod.yaml: exit status
#                       2, RestartPreventExitStatus=2 keeps NRestarts, the unit
#                       failed, not restarting
# One line per check, "SYSTEMD: PASS name: what was seen" or "SYSTEMD: FAIL
# name: why", then "SYSTEMD: N passed, M failed", on the serial console; the
# guest then powers off.
set -uo pipefail
export PATH=/usr/sbin:/usr/bin:/sbin:/bin
here=/opt/clm-systemd-test
work=/var/tmp/clm-systemd-test
mkdir -p "$work"
unit=clm-servod.service
config=/etc/clm-servo/servod.yaml
passed=0 failed=0

report() {  # NAME STATUS(0 pass) MESSAGE
  if [ "$2" = 0 ]; then
    echo "SYSTEMD: PASS $1: $3"
    passed=$((passed + 1))
  else
    echo "SYSTEMD: FAIL $1: $3"
    failed=$((failed + 1))
    journalctl -u "$unit" --no-pager -n 15 -o short-monotonic 2>/dev/null | sed 's/^/SYSTEMD:   journal: /'
  fi
}
finish() {
  echo "SYSTEMD: $passed passed, $failed failed"
  sync
  systemctl poweroff --force --force
}
prop() { systemctl show -p "$1" --value "$unit"; }
# Monotonic seconds of the guest (CLOCK_MONOTONIC, as systemd's *Monotonic properties).
now_s() { awk '{ print $1 }' /proc/uptime; }
# Waits up to SECONDS for the shell condition COMMAND...; 0 when it held.
wait_until() {
  local seconds=$1
  shift
  local end=$(( $(date +%s) + seconds ))
  while ! "$@"; do
    [ "$(date +%s)" -ge "$end" ] && return 1
    sleep 0.2
  done
}
# The unit's journal since the epoch second SINCE, after journald has written what it has.
journal_since() {
  journalctl --sync 2>/dev/null
  journalctl -u "$unit" --no-pager -o cat --since "@$1" 2>/dev/null
}

echo "SYSTEMD: guest up: kernel $(uname -r), systemd $(systemctl --version | awk 'NR == 1 { print $2 }'), $(nproc) CPU," \
     "booted in $(systemd-analyze 2>/dev/null | sed -n 's/^Startup finished in //p' | head -1)"

# ---- installed ---------------------------------------------------------------------
if dpkg -i "$here/clm-servo.deb" > "$work/dpkg.log" 2>&1 && systemctl daemon-reload &&
   [ "$(systemctl show -p LoadState --value "$unit")" = loaded ] &&
   [ "$(systemctl show -p FragmentPath --value "$unit")" = /lib/systemd/system/clm-servod.service ]; then
  report installed 0 "$(dpkg-query -W -f='${Package} ${Version}' clm-servo), unit $(prop FragmentPath) with drop-in $(prop DropInPaths)"
else
  report installed 1 "dpkg -i or the unit: $(tail -3 "$work/dpkg.log" | tr '\n' ' ') LoadState $(prop LoadState) FragmentPath $(prop FragmentPath)"
  finish
fi
# The guest's clock jumps over the time it waits for the host's disk
# (-icount sleep=off; docs/hil.md, "The systemd tier"): on a slow host disk a
# first start that reads the daemon and its 30-odd libraries from the image
# took over TimeoutStartSec=10 of guest time. What the checks start is read
# into the guest's page cache first, so that they time systemd and the
# daemon, not the host's disk.
warm_up() {
  local program
  for program in "$@"; do
    cat "$program" > /dev/null
    ldd "$program" | awk '/=> \// { print $3 } /^[[:space:]]*\// { print $1 }' | xargs -r cat > /dev/null
  done
}
warm_up /usr/bin/clm-servod /usr/bin/clm /usr/bin/lcm-logger /bin/systemctl /bin/journalctl
cat /etc/clm-servo/*.yaml > /dev/null
lcm_url=$(sed -n 's/^  lcm_url: "\(.*\)".*/\1/p' "$config")
ctl() { clm ctl --lcm-url "$lcm_url" "$@"; }

# ---- ready ---------------------------------------------------------------------------
start_epoch=$(date +%s)
if systemctl start "$unit" && [ "$(prop ActiveState)/$(prop SubState)" = active/running ]; then
  report ready 0 "systemctl start returned, $(prop ActiveState) ($(prop SubState)), MainPID $(prop MainPID), status '$(prop StatusText)'"
else
  report ready 1 "systemctl start: $(prop ActiveState) ($(prop SubState)), Result $(prop Result)"
fi

# ---- watchdog_pings ------------------------------------------------------------------
first=$(prop WatchdogTimestampMonotonic)
watchdog_usec=$(prop WatchdogUSec)
# A ping every 0.5 s: the timestamp advances within 2 s.
advanced() { second=$(prop WatchdogTimestampMonotonic); [ -n "$second" ] && [ "$second" -gt "${first:-0}" ]; }
if ! [ "${first:-0}" -gt 0 ] 2>/dev/null; then
  report watchdog_pings 1 "WatchdogTimestampMonotonic '$first' after systemctl start, expected a ping's time (WatchdogUSec $watchdog_usec)"
elif ! wait_until 2 advanced; then
  report watchdog_pings 1 "WatchdogTimestampMonotonic still ${first} us 2 s later, expected a ping every 0.5 s (WatchdogUSec $watchdog_usec)"
elif ! journal_since "$start_epoch" | grep -q "systemd watchdog every 0.5 s"; then
  report watchdog_pings 1 "no 'systemd watchdog every 0.5 s' in the journal: $(journal_since "$start_epoch" | grep running: )"
else
  report watchdog_pings 0 "WatchdogTimestampMonotonic ${first} -> ${second} us (WatchdogUSec $watchdog_usec)"
fi

# ---- sandbox_realtime ----------------------------------------------------------------
check_sandbox() {
  local pid uid vmlck fifo_threads state_uid priority
  pid=$(prop MainPID)
  [ "$pid" -gt 0 ] || { why="no MainPID"; return 1; }
  uid=$(awk '/^Uid:/ { print $2 }' "/proc/$pid/status")
  vmlck=$(awk '/^VmLck:/ { print $2 }' "/proc/$pid/status")
  priority=$(sed -n 's/^  priority: \([0-9]*\).*/\1/p' "$config")
  # Field 41 of /proc/PID/task/TID/stat is the policy (1 SCHED_FIFO), 40 the real-time priority.
  fifo_threads=$(for stat in /proc/"$pid"/task/*/stat; do
                   sed 's/^.*) //' "$stat" | awk -v p="$priority" '$39 == 1 && $38 == p { print "x" }'
                 done | wc -l)
  state_uid=$(stat -L -c %u /var/lib/clm-servod 2>/dev/null || echo none)
  seen="uid $uid (unit's UID $(prop UID)), VmLck $vmlck kB, $fifo_threads thread(s) SCHED_FIFO $priority,"
  seen="$seen /var/lib/clm-servod -> $(readlink /var/lib/clm-servod) owned by $state_uid"
  why=$seen
  [ "$uid" -ne 0 ] && [ "$uid" = "$(prop UID)" ] || { why="not the unit's dynamic user: $seen"; return 1; }
  [ "${vmlck:-0}" -gt 0 ] || { why="no memory locked: $seen"; return 1; }
  [ "$fifo_threads" = 1 ] || { why="not exactly one SCHED_FIFO $priority thread: $seen"; return 1; }
  [ "$state_uid" = "$uid" ] || { why="StateDirectory not the service user's: $seen"; return 1; }
  if journal_since "$start_epoch" | grep -q "warning"; then
    why="warnings in the journal: $(journal_since "$start_epoch" | grep warning | head -3 | tr '\n' ' ')"
    return 1
  fi
}
check_sandbox
report sandbox_realtime $? "$why"

# ---- stop_disables_axis --------------------------------------------------------------
# state_rows CSV: "N FIRST LAST DISABLED STAYS" of the recorded states in CSV
# (clm log2csv --format full): how many, the first and the last state, how
# many from the first disabled one (0) on, and "stays" if none after it is
# enabled again ("re-enabled" otherwise).
state_rows() {
  awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == "state") c = i; next }
           { s = $c; if (NR == 2) first = s; if (s == 0 && seen_zero == "") seen_zero = NR; if (seen_zero != "" && s != 0) back = 1; last = s; n++ }
           END { printf "%d %s %s %d %s\n", n, first, last, (seen_zero == "" ? 0 : n - seen_zero + 2), (back ? "re-enabled" : "stays") }' "$1"
}
check_stop() {
  local status pid logger main_status result journal disabled_line exiting_line rows
  ctl clear-fault > /dev/null 2>&1 || true
  ctl enable > "$work/enable.out" 2>&1 || { why="clm ctl enable: $(cat "$work/enable.out")"; return 1; }
  status=$(ctl status 2>&1) || { why="clm ctl status: $status"; return 1; }
  grep -qx "state: enabled" <<< "$status" || { why="not enabled after clm ctl enable: $(grep '^state\|^fault' <<< "$status" | tr '\n' ' ')"; return 1; }
  rm -f "$work/stop.lcm"
  lcm-logger --lcm-url="$lcm_url" --channel=CLM_SERVO_STATE --quiet "$work/stop.lcm" > "$work/logger.out" 2>&1 &
  logger=$!
  # The logger subscribes before the stop. Fixed pauses here and below: the
  # guest's time is counted in instructions (docs/hil.md), so a loaded host
  # does not shorten them, and polling the log with clm log2csv would cost
  # the one vCPU process start-ups beside the daemon (in the HIL guest that
  # expired the simulated drive's watchdog).
  sleep 0.5
  pid=$(prop MainPID)
  local stop_epoch
  stop_epoch=$(date +%s)
  systemctl stop "$unit" || { why="systemctl stop failed"; kill "$logger"; return 1; }
  sleep 0.3  # the last states reach the logger
  kill -INT "$logger"
  wait "$logger"
  main_status=$(prop ExecMainStatus) result=$(prop Result)
  journal=$(journal_since "$stop_epoch")
  disabled_line=$(grep -n "axis disabled .* after the stop request" <<< "$journal" | head -1 | cut -d: -f1)
  exiting_line=$(grep -n "exiting .* after the stop request" <<< "$journal" | head -1 | cut -d: -f1)
  # The recorded states, oldest first: enabled (1) at the start, disabled (0) at the end.
  clm log2csv --log "$work/stop.lcm" --output "$work/stop.csv" --format full > "$work/log2csv.out" 2>&1 ||
      { why="clm log2csv: $(cat "$work/log2csv.out")"; return 1; }
  read -r n first last disabled_rows stays < <(state_rows "$work/stop.csv")
  seen="MainPID $pid exited with status $main_status (Result $result); the journal: '$(sed -n "${disabled_line:-0}p" <<< "$journal")',"
  seen="$seen '$(sed -n "${exiting_line:-0}p" <<< "$journal")'; $n recorded states: first $first, last $last, the last $disabled_rows disabled"
  why=$seen
  [ "$main_status" = 0 ] && [ "$result" = success ] ||
      { why="exit status $main_status (Result $result), expected 0 (success): $seen"; return 1; }
  [ -n "$disabled_line" ] && [ -n "$exiting_line" ] ||
      { why="no 'axis disabled' or no 'exiting' line after the stop request in the journal: $seen"; return 1; }
  [ "$disabled_line" -lt "$exiting_line" ] || { why="'exiting' before 'axis disabled' in the journal: $seen"; return 1; }
  [ "$first" = 1 ] || { why="the first recorded state is $first, expected 1 (enabled): $seen"; return 1; }
  [ "$last" = 0 ] && [ "$stays" = stays ] ||
      { why="the recorded states end in state $last ($stays after the first disabled one), expected 0 throughout: $seen"; return 1; }
  [ "$disabled_rows" -ge 2 ] || { why="$disabled_rows disabled states at the end of the log, expected at least 2: $seen"; return 1; }
}
check_stop
report stop_disables_axis $? "$why"

# ---- watchdog_restart ----------------------------------------------------------------
check_watchdog_restart() {
  local pid0 restarts0 pid1 restarts1 stop_s stop_epoch ready_s
  systemctl start "$unit" || { why="systemctl start failed"; return 1; }
  pid0=$(prop MainPID) restarts0=$(prop NRestarts)
  stop_s=$(now_s) stop_epoch=$(date +%s)
  kill -STOP "$pid0"
  restarted() { [ "$(prop NRestarts)" -gt "$restarts0" ] && [ "$(prop ActiveState)/$(prop SubState)" = active/running ]; }
  if ! wait_until 30 restarted; then
    why="no restart within 30 s of SIGSTOP: NRestarts $(prop NRestarts), $(prop ActiveState) ($(prop SubState))"
    kill -CONT "$pid0" 2>/dev/null
    return 1
  fi
  ready_s=$(now_s)
  pid1=$(prop MainPID) restarts1=$(prop NRestarts)
  why="SIGSTOP to MainPID $pid0; systemd: '$(journal_since "$stop_epoch" | grep -m1 -i "watchdog timeout")';"
  why="$why NRestarts $restarts0 -> $restarts1, MainPID $pid1, active (running) again $(awk -v a="$stop_s" -v b="$ready_s" 'BEGIN { printf "%.1f", b - a }') s after the SIGSTOP"
  [ "$restarts1" = $((restarts0 + 1)) ] && [ "$pid1" != "$pid0" ] && [ "$pid1" -gt 0 ] || return 1
  kill -0 "$pid0" 2>/dev/null && { why="the stopped process $pid0 is still there: $why"; return 1; }
  journal_since "$stop_epoch" | grep -qi "watchdog timeout" || { why="no watchdog timeout in the journal: $why"; return 1; }
  return 0
}
check_watchdog_restart
report watchdog_restart $? "$why"

# ---- config_error_no_restart ---------------------------------------------------------
check_config_error() {
  local restarts_after restarts_later state result main_status
  systemctl stop "$unit"
  cp "$config" "$work/servod.yaml.orig"
  sed -i 's/^  rate_hz: 1000$/  rate_hz: -1000/' "$config"
  grep -q "^  rate_hz: -1000$" "$config" || { why="could not break $config"; return 1; }
  local error_epoch
  error_epoch=$(date +%s)
  systemctl start "$unit" 2> "$work/start.err" && { why="systemctl start succeeded on a broken configuration"; return 1; }
  restarts_after=$(prop NRestarts)
  # RestartSec=1: a restart would have come within this.
  sleep 4
  restarts_later=$(prop NRestarts) state="$(prop ActiveState)/$(prop SubState)" result=$(prop Result) main_status=$(prop ExecMainStatus)
  why="exit status $main_status (Result $result), NRestarts $restarts_after -> $restarts_later after 4 s, $state;"
  why="$why journal: '$(journal_since "$error_epoch" | grep -m1 "rate_hz")'"
  cp "$work/servod.yaml.orig" "$config"
  [ "$main_status" = 2 ] && [ "$result" = exit-code ] || { why="expected exit status 2 (Result exit-code): $why"; return 1; }
  [ "$restarts_after" = 0 ] && [ "$restarts_later" = "$restarts_after" ] ||
      { why="expected NRestarts 0 and no restart within 4 s (RestartSec=1): $why"; return 1; }
  [ "$state" = failed/failed ] || { why="expected the unit failed/failed: $why"; return 1; }
}
check_config_error
report config_error_no_restart $? "$why"

finish
