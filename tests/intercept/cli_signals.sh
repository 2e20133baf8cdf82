#!/usr/bin/env bash
# Signals to `contego run` (embedded monitor and --socket) and `contego
# monitor`, with real processes: a rover loop on a virtual bus.
#  - SIGINT, SIGTERM, SIGHUP to `contego run --policy`: exit 128+N, the audit
#    log records the signal and a safe state, the virtual GoPiGo2 reads back
#    stopped (motion 0x78), and the program is gone.
#  - SIGKILL to `contego run`: the program dies with it (PR_SET_PDEATHSIG).
#  - A monitor stopped or killed under `contego run --socket`: exit 3, the
#    program ended, the reason on stderr.
#  - The same three signals to `contego run --socket`: exit 128+N, the
#    program is gone and the monitor logs a safe state for the closed
#    connection; SIGHUP to the monitor is logged and it keeps serving;
#    SIGTERM to it drives the safe state and exits 0.
# Usage: cli_signals.sh CONTEGO POLICIES_DIR SCRIPTS_DIR
set -uo pipefail
contego="$1" policies="$2" scripts="$3"
# shellcheck source=tests/intercept/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/cli_common.sh"
FAIL_SHOW=("*.err" "*.jsonl" "*.state")
declare -A number=([INT]=2 [TERM]=15 [HUP]=1 [KILL]=9)

# event KIND TEXT FILE: an audit event of that kind whose detail contains TEXT.
event() { grep -aqF -- "$2" <(grep -aF "\"kind\":\"$1\"" "$3"); }
count() { grep -acF "\"kind\":\"$1\"" "$2"; }

# --- embedded monitor -------------------------------------------------------
for sig in INT TERM HUP; do
  "$contego" run --policy "$policies/rover.policy" --task follower --virtual-bus 1 \
    --audit "$dir/$sig.jsonl" --virtual-state "$dir/$sig.state" \
    -- /usr/bin/python3 "$scripts/rover_loop.py" "$dir/$sig.pid" >"$dir/$sig.out" 2>"$dir/$sig.err" &
  run_pid=$!
  wait_for "$dir/$sig.pid" || fail "$sig: the program did not start"
  child=$(cat "$dir/$sig.pid")
  kill -"$sig" "$run_pid"
  wait "$run_pid"
  code=$?
  [[ $code -eq $((128 + ${number[$sig]})) ]] || fail "$sig: contego run exited $code"
  gone "$child" || fail "$sig: the program (pid $child) outlived contego run"
  event signal "SIG$sig: ended the supervised program" "$dir/$sig.jsonl" ||
    fail "$sig: no signal event in the audit log"
  event safe-state "contego run: SIG$sig" "$dir/$sig.jsonl" ||
    fail "$sig: no safe-state event for the signal"
  # Causal order: the signal, then the program's exit it caused.
  signal_line=$(grep -n '"kind":"signal"' "$dir/$sig.jsonl" | head -n1 | cut -d: -f1)
  exit_line=$(grep -n '"detail":"task [0-9]* ([a-z]*) exited' "$dir/$sig.jsonl" | head -n1 | cut -d: -f1)
  [[ -n "$signal_line" && -n "$exit_line" && $signal_line -lt $exit_line ]] ||
    fail "$sig: the signal record (line $signal_line) is not before the task's exit (line $exit_line)"
  grep -q "gopigo2 0x08 motion=0x78" "$dir/$sig.state" ||
    fail "$sig: the GoPiGo2 is not stopped: $(cat "$dir/$sig.state")"
  grep -q "SIG$sig: ended the program; safe state applied" "$dir/$sig.err" ||
    fail "$sig: no message"
  echo "embedded $sig: ok"
done

# SIGKILL: nothing can be driven, but the program must not run on.
"$contego" run --policy "$policies/rover.policy" --task follower --virtual-bus 1 \
  --audit "$dir/KILL.jsonl" -- /usr/bin/python3 "$scripts/rover_loop.py" "$dir/KILL.pid" \
  >/dev/null 2>&1 &
run_pid=$!
wait_for "$dir/KILL.pid" || fail "KILL: the program did not start"
child=$(cat "$dir/KILL.pid")
kill -KILL "$run_pid"
wait "$run_pid" 2>/dev/null
gone "$child" || fail "KILL: the program (pid $child) outlived its supervisor"
echo "embedded KILL: ok"

# --- socket mode ------------------------------------------------------------
sock="$dir/monitor.sock"
"$contego" monitor --policy "$policies/rover.policy" --virtual-bus 1 --socket "$sock" \
  --audit "$dir/monitor.jsonl" --virtual-state "$dir/monitor.state" 2>"$dir/monitor.err" &
monitor_pid=$!
wait_for_socket "$sock" || fail "the monitor did not start"
for sig in INT TERM HUP; do
  kill -HUP "$monitor_pid"  # logged; the monitor keeps serving (the next run connects)
  "$contego" run --socket "$sock" --task follower \
    -- /usr/bin/python3 "$scripts/rover_loop.py" "$dir/s$sig.pid" >"$dir/s$sig.out" 2>"$dir/s$sig.err" &
  run_pid=$!
  wait_for "$dir/s$sig.pid" || fail "socket $sig: the program did not start"
  child=$(cat "$dir/s$sig.pid")
  before=$(count safe-state "$dir/monitor.jsonl")
  kill -"$sig" "$run_pid"
  wait "$run_pid"
  code=$?
  [[ $code -eq $((128 + ${number[$sig]})) ]] || fail "socket $sig: contego run exited $code"
  gone "$child" || fail "socket $sig: the program (pid $child) outlived contego run"
  for _ in $(seq 50); do
    [[ $(count safe-state "$dir/monitor.jsonl") -gt $before ]] && break
    sleep 0.1
  done
  [[ $(count safe-state "$dir/monitor.jsonl") -gt $before ]] && event safe-state "exited" "$dir/monitor.jsonl" ||
    fail "socket $sig: the monitor logged no safe state for the closed connection"
  kill -0 "$monitor_pid" || fail "socket $sig: the monitor died"
  echo "socket $sig: ok"
done
event signal "SIGHUP: still serving" "$dir/monitor.jsonl" || fail "no SIGHUP event"
stop_monitor || fail "the monitor exited $? on SIGTERM"
event safe-state "monitor stopping (SIGTERM)" "$dir/monitor.jsonl" ||
  fail "monitor: no safe state for SIGTERM"
grep -q "gopigo2 0x08 motion=0x78" "$dir/monitor.state" || fail "monitor: the GoPiGo2 is not stopped"

# A monitor that goes away ends the supervised program (contego run --socket
# exits 3 and says why) instead of leaving it looping on EIO.
for how in TERM KILL; do
  "$contego" monitor --policy "$policies/rover.policy" --virtual-bus 1 --socket "$sock" \
    --audit "$dir/lost$how.jsonl" >"$dir/lost$how-monitor.out" 2>"$dir/lost$how-monitor.err" &
  monitor_pid=$!
  wait_for_socket "$sock" || fail "lost $how: the monitor did not start"
  "$contego" run --socket "$sock" --task follower \
    -- /usr/bin/python3 "$scripts/rover_loop.py" "$dir/lost$how.pid" >"$dir/lost$how.out" \
    2>"$dir/lost$how.err" &
  run_pid=$!
  wait_for "$dir/lost$how.pid" || fail "lost $how: the program did not start"
  child=$(cat "$dir/lost$how.pid")
  kill -"$how" "$monitor_pid"
  wait "$monitor_pid" 2>/dev/null
  monitor_pid=""
  wait "$run_pid"
  code=$?
  [[ $code -eq 3 ]] || fail "lost $how: contego run exited $code"
  gone "$child" || fail "lost $how: the program (pid $child) outlived contego run"
  grep -q "the monitor at .* went away" "$dir/lost$how.err" || fail "lost $how: no reason given"
  rm -f "$sock"
  echo "monitor lost ($how): ok"
done
echo "ok"
