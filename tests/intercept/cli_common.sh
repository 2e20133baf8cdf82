# shellcheck shell=bash
# Shared by the command-line tests of this folder (sourced, not run): a
# scratch directory removed on exit, with a monitor daemon killed if one is
# still running, a `fail` that shows what the programs wrote, and waits.
#
# After sourcing: $dir is the scratch directory; set monitor_pid to a
# monitor's pid while one runs (empty once it has been stopped and reaped);
# FAIL_SHOW holds the globs (relative to $dir) whose tails `fail` prints.

dir="$(mktemp -d)"
monitor_pid=""
FAIL_SHOW=("*")
cli_cleanup() {
  [[ -n "$monitor_pid" ]] && kill -KILL "$monitor_pid" 2>/dev/null
  rm -rf "$dir"
}
trap cli_cleanup EXIT

# fail MESSAGE: prints it and the last lines of the files FAIL_SHOW names, exits 1.
fail() {
  echo "FAIL: $*"
  local pattern f
  for pattern in "${FAIL_SHOW[@]}"; do
    for f in "$dir"/$pattern; do
      [[ -f "$f" ]] && { echo "--- $f"; tail -n 20 "$f" | tr -d '\0'; }
    done
  done
  exit 1
}

wait_for() {  # FILE: until it exists and is not empty (10 s)
  for _ in $(seq 100); do [[ -s "$1" ]] && return 0; sleep 0.1; done
  return 1
}

wait_for_socket() {  # PATH: until a socket is there (10 s)
  for _ in $(seq 100); do [[ -S "$1" ]] && return 0; sleep 0.1; done
  return 1
}

gone() {  # PID: not running (a zombie counts as gone only once reaped by its parent)
  for _ in $(seq 50); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.1; done
  return 1
}

stop_monitor() {  # the monitor in monitor_pid: SIGTERM, reaped; its exit status returned
  local code=0
  kill -TERM "$monitor_pid"
  wait "$monitor_pid" 2>/dev/null || code=$?
  monitor_pid=""
  return "$code"
}
