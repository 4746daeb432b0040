# shellcheck shell=bash disable=SC2034,SC2154
# Shell helpers of the process-level test scripts (sourced, not run):
# tests/servod/servod_process_test.sh, tests/tools/commission_live_test.sh,
# tests/hil/run_hil.sh and tests/hil/run_faults.sh. Bash; works under
# `set -euo pipefail` (call the functions that can fail in an `if` or
# before `||`). In the HIL guest it lies at the same path under /hil/src
# (tests/hil/qemu/make_initramfs.sh).
#
# Variables the functions read, set by the sourcing script: clm, servod
# (the programs), url (the daemon's LCM URL), source_dir, iface (the CAN
# interface). Processes started here are appended to `pids`; `created_iface`
# names a vcan interface made here; cleanup_processes (the scripts' EXIT
# trap) kills the one and deletes the other.

pids=()
created_iface=""

# A command that fails outside an `if` or a `||` ends a `set -e` script
# without a word of its own; this names the script, the line and the status,
# so that a failed test never has an empty output.
# Scripts without `set -e` go on after a failing command: nothing is said then.
trap 'err_trap_status=$?; [[ $- == *e* ]] && echo "${BASH_SOURCE[0]##*/}: line $LINENO: a command exited with status $err_trap_status (set -e); the test stops here" >&2' ERR

# The operators' key of the test's daemons and clients (config/command_key.hpp,
# read from $CLM_SERVO_KEY_FILE by both): a fresh one, unless the caller names one.
if [ -z "${CLM_SERVO_KEY_FILE:-}" ]; then
  key_dir=$(mktemp -d "${TMPDIR:-/tmp}/clm_key.XXXXXX")
  (umask 077; head -c 32 /dev/urandom > "$key_dir/command.key")
  export CLM_SERVO_KEY_FILE=$key_dir/command.key
fi

# ---- paths, `clm ctl` and its status ---------------------------------------------

# The absolute path of `path` (its directory must exist).
absolute() { echo "$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"; }

# `clm ctl` of the daemon at $url; waits 2 s for a status or an ack unless --timeout-s.
ctl() { "$clm" ctl --lcm-url "$url" "$@"; }

# `ctl ARGS...` expecting a refusal (docs/design-decisions.md, "Exit status
# and error messages"): exit status 1, nothing on stdout, one stderr line
# "clm ctl: error: TEXT"; sets `reply` to TEXT (the ack's text). Calls the
# sourcing script's `fail` otherwise.
ctl_refused() {
  local err_file out err rc=0
  err_file=$(mktemp)
  out=$(ctl "$@" 2> "$err_file") || rc=$?
  err=$(cat "$err_file")
  rm -f "$err_file"
  [ "$rc" = 1 ] || fail "ctl $*: exit status $rc, expected 1 (refused): stdout '$out', stderr '$err'"
  [ -z "$out" ] || fail "ctl $*: the refusal printed '$out' on stdout"
  [ "$(printf '%s\n' "$err" | wc -l)" = 1 ] || fail "ctl $*: not one line on stderr: '$err'"
  [[ $err == "clm ctl: error: "* ]] || fail "ctl $*: stderr '$err' lacks 'clm ctl: error: '"
  reply=${err#clm ctl: error: }
}

# Prints "FAIL: MESSAGE", the fault lines of the daemon's status (when one
# answers on $url) and the clm-servod stderr LOG files, then exits 1.
fail_with_status() {
  local message=$1
  shift
  echo "FAIL: $message" >&2
  ctl status 2>/dev/null | grep -E "^(state|fault|fault_reason|fault_cycle):" >&2 || true
  echo "--- clm-servod stderr:" >&2
  cat "$@" >&2 2>/dev/null || true
  exit 1
}

# The value of `name: value` line NAME in TEXT (a `clm ctl status`).
field() { sed -n "s/^$1: //p" <<< "$2"; }

# wait_homing PREFIX SECONDS: until the `homing` field of `clm ctl status`
# starts with PREFIX ("idle, commutation found, homed"); sets `status` and
# `homed` (that field). Returns 1 on a fault or after SECONDS.
wait_homing() {
  local prefix=$1 deadline=$((SECONDS + $2))
  homed=""
  while [ $SECONDS -lt $deadline ]; do
    if status=$(ctl status --timeout-s 1 2> /dev/null); then
      [ "$(field state "$status")" = fault ] && return 1
      homed=$(field homing "$status")
      [[ $homed == "$prefix"* ]] && return 0
    fi
    sleep 0.5
  done
  return 1
}

# The count after NAME (missing, late, rejected, ...) in the frames line of STATUS.
counter() { field frames "$1" | sed -n "s/.*$2 \([0-9]*\).*/\1/p"; }

# log_extent LOG: reads the CLM_SERVO_STATE log that lcm-logger is writing to
# LOG (clm log2csv into LOG.probe.csv) and sets log_states (the states in it),
# log_first and log_last (their first and last cycle; -1 while it has none).
# lcm-logger writes through a buffer, so the file usually ends inside an
# event, which clm log2csv refuses naming the event's byte: then the events
# before that byte are read (a copy, LOG.probe).
log_extent() {
  local cut
  log_states=0 log_first=-1 log_last=-1
  if ! "$clm" log2csv --log "$1" --format full --output "$1.probe.csv" > /dev/null 2> "$1.probe.err"; then
    cut=$(sed -n 's/.*truncated: .* at byte \([0-9]*\).*/\1/p' "$1.probe.err" | head -n 1)
    [ -n "$cut" ] && [ "$cut" -gt 0 ] || return 0
    head -c "$cut" "$1" > "$1.probe"
    "$clm" log2csv --log "$1.probe" --format full --output "$1.probe.csv" > /dev/null 2>&1 || return 0
  fi
  read -r log_states log_first log_last < <(awk -F, '
      NR == 1 { for (i = 1; i <= NF; ++i) if ($i == "cycle") c = i; next }
      { ++n; if (n == 1) first = int($c); last = int($c) }
      END { if (n) print n, first, last; else print 0, -1, -1 }' "$1.probe.csv")
}

# record_states LOG ERR_FILE: lcm-logger on CLM_SERVO_STATE of $url into LOG
# (stderr to ERR_FILE) in the set-up docs/telemetry.md ("Logs") recommends:
# SCHED_FIFO 10 where chrt and the rights exist (fifo), a 4 MiB receive
# buffer. At normal priority a loaded host holds the logger back long enough
# for LCM's queue of 30 messages to overflow, and the log misses states.
# Sets logger_pid.
record_states() {
  $(fifo 10) lcm-logger -q --lcm-url="$url&recv_buf_size=4194304" --channel=CLM_SERVO_STATE "$1" 2> "$2" &
  logger_pid=$!
  pids+=("$logger_pid")
}

# wait_log_reaches LOG CYCLE [SECONDS]: waits (up to SECONDS, default 10)
# until the CLM_SERVO_STATE log that lcm-logger is writing to LOG holds cycle
# CYCLE or later, so that a logger the host keeps waiting is not stopped
# before it has what the check reads. Returns 1 if it never does; log_extent's
# variables then say how far it got (the caller's message names the check,
# its bound and log_last), and waited_s the seconds waited.
wait_log_reaches() {
  local log=$1 cycle=$2 seconds=${3:-10} start
  start=$(date +%s)
  while :; do
    log_extent "$log"
    waited_s=$(( $(date +%s) - start ))
    [ "$log_states" -gt 0 ] && [ "$log_last" -ge "$cycle" ] && return 0
    [ "$waited_s" -ge "$seconds" ] && return 1
    sleep 0.2
  done
}

# wait_log_started LOG [SECONDS]: waits (up to SECONDS, default 10) until the
# CLM_SERVO_STATE log that lcm-logger is writing to LOG holds a state: the
# logger has subscribed, so what the test does next is recorded (a fixed
# pause is not: on a loaded host lcm-logger may start later). Returns 1 if it
# never does (waited_s: the seconds waited).
wait_log_started() { wait_log_reaches "$1" 0 "${2:-10}"; }

# py_check ARGS... < SCRIPT: runs the Python check SCRIPT with ARGS (sys.argv[1:]).
# What it prints goes to stdout; when one of its asserts fails, the assert's
# message alone (instead of a traceback on stderr) and exit status 1, so that
# `verdict=$(py_check ...) || fail "...: $verdict"` names the check that failed.
py_check() {
  python3 -c 'import sys
source = sys.stdin.read()
sys.argv = ["check"] + sys.argv[1:]
try:
    exec(compile(source, "check", "exec"), {"__name__": "__main__"})
except AssertionError as e:
    print(e if str(e) else "an assert without a message failed")
    sys.exit(1)' "$@"
}

# Waits up to SECONDS for the first status of the daemon PID, one `clm ctl
# status --timeout-s 1` at a time (at least one, however long a loaded host
# makes each take): sets `status`; 0 when one came, 1 when none did within
# SECONDS, 2 when PID exited meanwhile.
wait_for_status() {
  local pid=$1 seconds=$2 start
  start=$(date +%s)
  status=""
  while :; do
    status=$(ctl status --timeout-s 1 2>/dev/null) && return 0
    kill -0 "$pid" 2>/dev/null || return 2
    [ $(( $(date +%s) - start )) -lt "$seconds" ] || return 1
  done
}

# ---- processes -------------------------------------------------------------------

# Sends SIGNAL (default TERM) to PID and waits up to TENTHS × 0.1 s; returns
# its exit status, or 255 if it is still running.
stop_process() {
  local pid=$1 tenths=$2 signal=${3:-TERM}
  kill "-$signal" "$pid" 2>/dev/null
  for _ in $(seq 1 "$tenths"); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  kill -0 "$pid" 2>/dev/null && return 255
  wait "$pid"
}

# Kills (SIGKILL) every process in `pids`, deletes `created_iface` and the
# key made here: the EXIT trap.
cleanup_processes() {
  local pid
  for pid in "${pids[@]}"; do kill -KILL "$pid" 2>/dev/null || true; done
  [ -n "$created_iface" ] && ip link del dev "$created_iface" 2>/dev/null
  [ -n "${key_dir:-}" ] && rm -rf "$key_dir"
  return 0
}

# The command prefix that runs a program SCHED_FIFO at PRIORITY where chrt
# (util-linux) and the rights exist, else nothing. Used unquoted, so that $!
# is the program's own pid (chrt execs it).
fifo() {
  if command -v chrt > /dev/null && chrt -f "$1" true 2> /dev/null; then echo "chrt -f $1"; fi
}

# Starts clm-servod on CONFIG, stderr to ERR_FILE, in the background: sets
# servod_pid. The environment of the call is the daemon's (NOTIFY_SOCKET=...
# start_daemon ...).
start_daemon() {
  "$servod" --config "$1" 2> "$2" &
  servod_pid=$!
  pids+=("$servod_pid")
}

# ---- the bus (HIL) -----------------------------------------------------------------

# Sets `iface`: HIL_CAN if set, else a vcan interface PREFIX<pid> made here
# (root), else vcan0 if it exists; else prints the skip line and exits 77.
# Then brings it up: 1 when it is not up.
start_bus() {
  iface=${HIL_CAN:-}
  if [ -z "$iface" ]; then
    local candidate="$1$(( $$ % 100000 ))"
    if ip link add dev "$candidate" type vcan 2>/dev/null; then
      iface=$candidate created_iface=$candidate
    elif [ -d /sys/class/net/vcan0 ]; then
      iface=vcan0
    else
      echo "HIL: skipped: cannot create a vcan interface (needs root and the vcan module) and there is no vcan0"
      exit 77
    fi
  fi
  ip link set up "$iface" 2>/dev/null
  [ -d "/sys/class/net/$iface" ] && [ "$(cat "/sys/class/net/$iface/operstate")" != down ]
}

# Records every frame on $iface with candump -L into LOG (stderr to ERR_FILE),
# SCHED_FIFO 60 where allowed: sets candump_pid. CANDUMP names the program.
start_candump() {
  $(fifo 60) "${CANDUMP:-candump}" -L -d "$iface" > "$1" 2> "$2" &
  candump_pid=$!
  pids+=("$candump_pid")
}

# Starts the simulated motor (`clm sim --can $iface`, config/motor-sim.yaml
# or the motor file $sim_motor, and ARGS) at SCHED_FIFO 70 where allowed, stdout to OUT_FILE, stderr to
# ERR_FILE: sets sim_pid; waits up to 10 s until it waits for SYNC (1: not up).
start_sim() {
  local out=$1 err=$2
  shift 2
  $(fifo 70) "$clm" sim --can "$iface" --motor "${sim_motor:-$source_dir/config/motor-sim.yaml}" "$@" > "$out" 2> "$err" &
  sim_pid=$!
  pids+=("$sim_pid")
  for _ in $(seq 1 100); do
    grep -q "waiting for SYNC" "$err" 2>/dev/null && return 0
    kill -0 "$sim_pid" 2>/dev/null || break
    sleep 0.1
  done
  grep -q "waiting for SYNC" "$err" 2>/dev/null
}

# ---- configuration files -------------------------------------------------------------

# Checks that every LINE is a whole line of the YAML FILE, comments aside;
# prints the first that is not and returns 1.
config_require() {
  local file=$1 line
  shift
  for line in "$@"; do
    grep -qxF -- "$line" <(sed 's/ *#.*//' "$file") || { echo "$line"; return 1; }
  done
}

# Copies the YAML file IN to OUT with each LINE ("<indent>key: value") in
# place of every line of IN with that indentation and key (value and comment
# replaced), then checks that each LINE is there (config_require: prints the
# first that is not and returns 1, e.g. a key IN lacks).
config_edit() {
  local in=$1 out=$2 line key text
  shift 2
  local script=()
  for line in "$@"; do
    key=${line%%:*}
    text=${line//\\/\\\\}
    text=${text//|/\\|}
    text=${text//&/\\&}
    script+=(-e "s|^$key:.*|$text|")
  done
  sed "${script[@]}" "$in" > "$out"
  config_require "$out" "$@"
}

# A copy OUT of the simulated motor file IN for a daemon without real-time
# rights on a loaded test host: the drive's setpoint watchdog at 0.1 s instead
# of 5 ms, so that a descheduled loop does not trip the simulated drive (a real
# axis keeps its own watchdog). With EXTRA lines (config_edit). Prints the line
# it could not set and returns 1.
loaded_host_motor() { config_edit "$1" "$2" "  watchdog_timeout_s: 0.1" "${@:3}"; }

# The lines that make config/servod.yaml's axis one with an absolute encoder,
# as the ideal plant's (tools/commission/plant_terms.py --write none): for
# config_edit, the motor file's (ABSOLUTE_MOTOR) and the configuration's
# (ABSOLUTE_CONFIG). For the process tests of other mechanisms than homing,
# which an unknown encoder zero would only delay; tests/servod/
# servod_homing_test.sh runs the shipped incremental one.
ABSOLUTE_MOTOR=("    encoder_power_up_offset_max_m: 0.0")
ABSOLUTE_CONFIG=("  method: none")

# OUT: the motor file IN with the drive's setpoint watchdog of a real drive,
# 5 ms (config/motor-real.yaml), for the suites that measure the loop's
# timing (the HIL suite): the shipped simulated motor's is sized for a host
# without a reserved CPU. Prints the line it could not set and returns 1.
strict_drive_watchdog() { config_edit "$1" "$2" "  watchdog_timeout_s: 0.005" "${@:3}"; }

# OUT: config/servod.yaml for a process test on a loaded host: an absolute
# path to the motor file ($work/motor-sim.yaml, the drive's watchdog relaxed
# by loaded_host_motor), no SCHED_FIFO, the real-time clock, the test's $url,
# overruns and stalls of up to 1 s tolerated, and EXTRA lines (config_edit).
# With PROCESS_TEST_ENCODER=absolute (the default) the encoder is absolute
# (ABSOLUTE_MOTOR, ABSOLUTE_CONFIG); with incremental, as shipped.
# Calls the script's fail.
process_test_config() {  # OUT EXTRA...
  local out=$1 motor=() config=()
  shift
  if [ "${PROCESS_TEST_ENCODER:-absolute}" = absolute ]; then
    motor=("${ABSOLUTE_MOTOR[@]}")
    config=("${ABSOLUTE_CONFIG[@]}")
  fi
  loaded_host_motor "$source_dir/config/motor-sim.yaml" "$work/motor-sim.yaml" "${motor[@]}" > /dev/null ||
      fail "motor: the watchdog or encoder line is missing after editing"
  config_edit "$source_dir/config/servod.yaml" "$out" "${config[@]}" \
      "motor_file: $work/motor-sim.yaml" "  priority: 0" "  clock: realtime" \
      "  lcm_url: \"$url\"" "  overrun_limit: 1000" "  stall_limit_s: 1" "$@" > /dev/null ||
      fail "config: a line is missing after editing $out"
}

# The value of the first line "KEY: value" of FILE, KEY with its indentation, comment aside.
config_value() { sed -n "s/^$2: \([^ #]*\).*/\1/p" "$1" | head -n 1; }
