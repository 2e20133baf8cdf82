#!/usr/bin/env bash
# The audit log and the monitor socket under faults (issue 11, parts 3-4),
# with real processes: `contego monitor` on a virtual bus, a task under
# `contego run --socket` moving the arm's servo 0 (scripts/arm_writer.py).
#  - /dev/full (and a FIFO) refused at start; a second monitor on one log refused.
#  - Full file system (a 320 KiB tmpfs; skipped with a reason if it cannot be
#    mounted): the task gets EIO, the monitor keeps answering, no SIGBUS;
#    every write the task saw succeed is a decision in the log, the servo
#    reads back the value of the last logged decision, the chain verifies;
#    once space is freed the task is served again after an audit-gap record.
#  - Truncation to zero and deletion while running: no crash, the chain
#    continues in the file at the path.
#  - SIGHUP after a move (logrotate create), SIGHUP and size rotation
#    (--audit-max-bytes): `contego audit` verifies the files as one chain and
#    counts every decision the task saw.
#  - A hostile client: 5,000 malformed requests and a reconnect flood write a
#    bounded number of event lines; the task's p50/p99 alone and under the flood.
#  - Descriptor exhaustion (RLIMIT_NOFILE 48, idle connections): accept fails,
#    the monitor keeps serving the task and takes a new one afterwards; the
#    per-uid cap and the hello timeout free descriptors.
# Usage: audit_faults.sh CONTEGO POLICIES_DIR SCRIPTS_DIR
set -uo pipefail
contego="$1" policies="$2" scripts="$3"
dir="$(mktemp -d)"
chmod 755 "$dir"
pids=()
mnt=""
cleanup() {
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null; done
  [[ -n "$mnt" ]] && umount -l "$mnt" 2>/dev/null
  rm -rf "$dir"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*"
  for f in "$dir"/*.err "$dir"/*.out; do [[ -f "$f" ]] && { echo "--- $f"; tail -n 15 "$f"; }; done
  exit 1
}
policy="$policies/arm.policy"
count() { grep -acF "\"kind\":\"$1\"" "$2"; }
wait_for() {  # FILE [tenths]: until it exists and is not empty
  for _ in $(seq "${2:-100}"); do [[ -s "$1" ]] && return 0; sleep 0.1; done
  return 1
}
field() { awk -v k="$1" '{for (i = 1; i < NF; i++) if ($i == k) print $(i + 1)}' "$2"; }
# wait_field FIELD FILE N: until the writer reports FIELD (ok: successful
# writes, failed: failed ones) at least N.
wait_field() {
  for _ in $(seq 100); do
    [[ -s "$2" ]] && (($(field "$1" "$2") >= $3)) && return 0
    sleep 0.1
  done
  return 1
}
wait_ok() { wait_field ok "$@"; }          # FILE N
wait_failed() { wait_field failed "$@"; }  # FILE N
# start_monitor NAME ARGS...: `contego monitor` on $dir/NAME.sock.
start_monitor() {
  local name="$1"
  shift
  "$contego" monitor --policy "$policy" --virtual-bus 1 --socket "$dir/$name.sock" \
    --budget-factor 0 --virtual-state "$dir/$name.state" "$@" 2>"$dir/$name.err" &
  monitor_pid=$!
  pids+=("$monitor_pid")
  for _ in $(seq 100); do [[ -S "$dir/$name.sock" ]] && return 0; sleep 0.1; done
  fail "$name: the monitor did not start"
}
# start_writer NAME SOCK PAUSE [LATENCY_FILE]
start_writer() {
  "$contego" run --socket "$2" --task arm_init -- /usr/bin/python3 "$scripts/arm_writer.py" \
    "$dir/$1.out" "$dir/$1.stop" "$3" ${4:+"$4"} 2>"$dir/$1.err" &
  writer_pid=$!
  pids+=("$writer_pid")
}
stop_writer() {  # NAME
  touch "$dir/$1.stop"
  wait "$writer_pid" 2>/dev/null
}
stop_monitor() {  # NAME: SIGTERM, must exit 0 (a SIGBUS would be 135)
  kill -TERM "$monitor_pid"
  wait "$monitor_pid"
  local code=$?
  [[ $code -eq 0 ]] || fail "$1: the monitor exited $code"
}
# decisions FILE...: arm_init's decisions in these logs.
decisions() { cat "$@" | grep -aF '"kind":"decision"' | grep -acF '"task_name":"arm_init"'; }

# --- refused at start -------------------------------------------------------
"$contego" monitor --policy "$policy" --virtual-bus 1 --socket "$dir/x.sock" --audit /dev/full \
  2>"$dir/full.err"
[[ $? -eq 2 ]] && grep -q "/dev/full is a character device" "$dir/full.err" ||
  fail "/dev/full was not refused: $(cat "$dir/full.err")"
"$contego" run --policy "$policy" --task arm_init --audit /dev/full -- /bin/true 2>"$dir/full.err"
[[ $? -eq 2 ]] || fail "contego run --audit /dev/full was not refused"
mkfifo "$dir/fifo"
"$contego" monitor --policy "$policy" --virtual-bus 1 --socket "$dir/x.sock" --audit "$dir/fifo" \
  2>"$dir/fifo.err"
[[ $? -eq 2 ]] && grep -q "is a FIFO" "$dir/fifo.err" || fail "a FIFO was not refused"
echo "refused at start (/dev/full, FIFO): ok"

start_monitor first --audit "$dir/shared.jsonl"
first=$monitor_pid
"$contego" monitor --policy "$policy" --virtual-bus 1 --socket "$dir/y.sock" \
  --audit "$dir/shared.jsonl" 2>"$dir/second.err"
[[ $? -eq 2 ]] && grep -q "in use by another writer (pid $first" "$dir/second.err" ||
  fail "a second writer was not refused: $(cat "$dir/second.err")"
stop_monitor first
"$contego" audit "$dir/shared.jsonl" >/dev/null || fail "the first monitor's log does not verify"
echo "second writer refused: ok"

# --- full file system -------------------------------------------------------
mkdir "$dir/small"
if mount -t tmpfs -o size=320k none "$dir/small" 2>"$dir/mount.err"; then
  mnt="$dir/small"
  start_monitor full --audit "$mnt/audit.jsonl"
  start_writer full "$dir/full.sock" 0.002
  wait_ok "$dir/full.out" 50 || fail "full: the task did not start"
  dd if=/dev/zero of="$mnt/filler" bs=4k 2>/dev/null
  wait_failed "$dir/full.out" 30 || fail "full: no write failed on a full file system"
  kill -0 "$monitor_pid" || fail "full: the monitor died"
  ok_before=$(field ok "$dir/full.out")
  grep -q "AUDIT LOG FAILURE" "$dir/full.err" || fail "full: no loud error on stderr"
  rm -f "$mnt/filler"
  wait_ok "$dir/full.out" $((ok_before + 20)) || fail "full: not served again after space came back"
  stop_writer full
  stop_monitor full
  ok=$(field ok "$dir/full.out") failed=$(field failed "$dir/full.out") last=$(field last "$dir/full.out")
  "$contego" audit "$mnt/audit.jsonl" >"$dir/full.audit" || fail "full: the log does not verify"
  logged=$(grep -aF '"kind":"decision"' "$mnt/audit.jsonl" | grep -aF '"task_name":"arm_init"' |
    grep -acF '"decision":"allow"')
  [[ $logged -eq $ok ]] || fail "full: the task saw $ok writes succeed, the log has $logged"
  # The servo reads back the last logged write (nothing acted unlogged).
  last_logged=$(grep -aF '"task_name":"arm_init"' "$mnt/audit.jsonl" | grep -aF '"decision":"allow"' |
    tail -n 1 | sed -E 's/.*"bytes":"06 00 00 ([0-9a-f]{2}) ([0-9a-f]{2})".*/\2\1/')
  readback=$(grep -o 'led0=[0-9]*/[0-9]*' "$dir/full.state" | cut -d/ -f2)
  [[ $((16#$last_logged)) -eq $readback && $readback -eq $last ]] ||
    fail "full: servo 0 reads $readback, last logged $((16#$last_logged)), task's last $last"
  [[ $(count audit-gap "$mnt/audit.jsonl") -ge 1 ]] || fail "full: no audit-gap record"
  echo "full file system: ok ($ok writes acted and logged, $failed refused with EIO, servo reads back $readback, no SIGBUS)"
  umount -l "$mnt"
  mnt=""
else
  echo "full file system: SKIPPED (cannot mount a tmpfs: $(cat "$dir/mount.err"))"
fi

# --- truncation and deletion while running ----------------------------------
start_monitor cut --audit "$dir/cut.jsonl"
start_writer cut "$dir/cut.sock" 0.002
wait_ok "$dir/cut.out" 50 || fail "cut: the task did not start"
truncate -s 0 "$dir/cut.jsonl"
ok1=$(field ok "$dir/cut.out")
wait_ok "$dir/cut.out" $((ok1 + 50)) || fail "cut: the task stopped after the truncation"
kill -0 "$monitor_pid" || fail "cut: the monitor died after the truncation"
head -n 1 "$dir/cut.jsonl" | grep -q '"kind":"continues"' || fail "cut: no continues record"
rm "$dir/cut.jsonl"
ok2=$(field ok "$dir/cut.out")
wait_ok "$dir/cut.out" $((ok2 + 50)) || fail "cut: the task stopped after the deletion"
[[ -f "$dir/cut.jsonl" ]] || fail "cut: no new log after the deletion"
stop_writer cut
stop_monitor cut
"$contego" audit "$dir/cut.jsonl" >"$dir/cut.audit" || fail "cut: the log does not verify"
grep -q "continues a chain" "$dir/cut.audit" || fail "cut: not reported as a continuation"
echo "truncation and deletion while running: ok"

# --- SIGHUP after a move (logrotate create) ---------------------------------
start_monitor hup --audit "$dir/hup.jsonl"
start_writer hup "$dir/hup.sock" 0.002
wait_ok "$dir/hup.out" 50 || fail "hup: the task did not start"
mv "$dir/hup.jsonl" "$dir/hup.jsonl.1"
kill -HUP "$monitor_pid"
ok1=$(field ok "$dir/hup.out")
wait_ok "$dir/hup.out" $((ok1 + 50)) || fail "hup: the task stopped after SIGHUP"
stop_writer hup
stop_monitor hup
grep -q "SIGHUP: still serving; reopened" "$dir/hup.err" || fail "hup: not reopened"
"$contego" audit "$dir/hup.jsonl.1" "$dir/hup.jsonl" >"$dir/hup.audit" ||
  fail "hup: the two files are not one chain"
[[ $(decisions "$dir/hup.jsonl.1" "$dir/hup.jsonl") -eq $(field ok "$dir/hup.out") ]] ||
  fail "hup: decisions lost across the move"
echo "SIGHUP reopen after a move: ok ($(tail -n 1 "$dir/hup.audit"))"

# --- size rotation and SIGHUP rotation --------------------------------------
start_monitor rot --audit "$dir/rot.jsonl" --audit-max-bytes 40000 --audit-keep 20
start_writer rot "$dir/rot.sock" 0.001
wait_ok "$dir/rot.out" 150 || fail "rot: the task did not start"
kill -HUP "$monitor_pid"
ok1=$(field ok "$dir/rot.out")
wait_ok "$dir/rot.out" $((ok1 + 300)) || fail "rot: the task stopped"
stop_writer rot
stop_monitor rot
files=()
for k in $(seq 20 -1 1); do [[ -f "$dir/rot.jsonl.$k" ]] && files+=("$dir/rot.jsonl.$k"); done
files+=("$dir/rot.jsonl")
((${#files[@]} >= 3)) || fail "rot: only ${#files[@]} file(s)"
"$contego" audit "${files[@]}" >"$dir/rot.audit" || fail "rot: not one chain: $(tail -n 3 "$dir/rot.audit")"
grep -q "SIGHUP: still serving; rotated" "$dir/rot.err" || fail "rot: SIGHUP did not rotate"
[[ $(decisions "${files[@]}") -eq $(field ok "$dir/rot.out") ]] || fail "rot: decisions lost"
for f in "${files[@]}"; do
  (($(stat -c %s "$f") <= 40000)) || fail "rot: $f is larger than --audit-max-bytes"
done
"$contego" audit "${files[1]}" | grep -q "continues a chain" || fail "rot: a rotated file alone"
"$contego" audit "${files[1]}" "${files[0]}" >/dev/null && fail "rot: files out of order verified"
echo "rotation (size and SIGHUP): ok (${#files[@]} files, $(grep 'one chain' "$dir/rot.audit"))"

# --- hostile client ---------------------------------------------------------
p99() { sort -n "$1" | awk '{v[NR] = $1} END {printf "p50 %.0f us, p99 %.0f us (%d writes)", v[int(NR * 0.5)], v[int(NR * 0.99)], NR}'; }
start_monitor flood --audit "$dir/flood.jsonl"
start_writer alone "$dir/flood.sock" 0.001 "$dir/alone.lat"
sleep 3
stop_writer alone
start_writer under "$dir/flood.sock" 0.001 "$dir/under.lat"
t0=$(date +%s.%N)
/usr/bin/python3 "$scripts/hostile_client.py" malformed "$dir/flood.sock" 5000 arm_init >"$dir/m.out" &
m=$!
/usr/bin/python3 "$scripts/hostile_client.py" reconnect "$dir/flood.sock" 3 >"$dir/r.out" &
r=$!
wait $m $r
t1=$(date +%s.%N)
stop_writer under
stop_monitor flood
malformed=$(count malformed "$dir/flood.jsonl")
peers=$(count peer "$dir/flood.jsonl")
seconds=$(awk -v a="$t0" -v b="$t1" 'BEGIN {printf "%d", b - a + 2}')
bound=$((20 * seconds + 20))
grep -q "5000 of 5000 answered" "$dir/m.out" || fail "flood: not every malformed request answered: $(cat "$dir/m.out")"
grep -aq 'client-error event(s) not written.*"kind":"suppressed"' "$dir/flood.jsonl" || fail "flood: no summary"
((malformed + peers <= bound)) ||
  fail "flood: $malformed malformed + $peers peer events in ${seconds}s (bound $bound)"
[[ $(count suppressed "$dir/flood.jsonl") -ge 1 ]] || fail "flood: no suppressed summary"
"$contego" audit "$dir/flood.jsonl" >/dev/null || fail "flood: the log does not verify"
echo "hostile client: ok ($(cat "$dir/m.out"); $(cat "$dir/r.out"); $malformed malformed + $peers peer lines written, $(count suppressed "$dir/flood.jsonl") suppressed summaries)"
echo "DoS figure (arm_init through contego run --socket, 1 ms apart): alone $(p99 "$dir/alone.lat"); under the flood $(p99 "$dir/under.lat")"

# --- descriptor exhaustion --------------------------------------------------
# No per-uid cap (the flood and the task share root's uid here), hello timeout 2 s.
prlimit --nofile=48:48 "$contego" monitor --policy "$policy" --virtual-bus 1 \
  --socket "$dir/fd.sock" --budget-factor 0 --audit "$dir/fd.jsonl" \
  --max-connections-per-uid 0 2>"$dir/fd.err" &
monitor_pid=$!
pids+=("$monitor_pid")
for _ in $(seq 100); do [[ -S "$dir/fd.sock" ]] && break; sleep 0.1; done
start_writer fd "$dir/fd.sock" 0.005
wait_ok "$dir/fd.out" 20 || fail "fd: the task did not start"
/usr/bin/python3 "$scripts/hostile_client.py" idle "$dir/fd.sock" 200 4 >"$dir/idle.out" &
idle=$!
sleep 1
ok1=$(field ok "$dir/fd.out")
wait_ok "$dir/fd.out" $((ok1 + 50)) || fail "fd: the task was not served during the exhaustion"
kill -0 "$monitor_pid" || fail "fd: the monitor died"
wait $idle
[[ $(count accept-failed "$dir/fd.jsonl") -ge 1 ]] || fail "fd: descriptors were never exhausted ($(cat "$dir/idle.out"))"
[[ $(count hello-timeout "$dir/fd.jsonl") -ge 1 ]] || fail "fd: no hello timeout"
# A new task is taken once the idle connections are gone.
"$contego" run --socket "$dir/fd.sock" --task arm_init -- /usr/bin/python3 -c \
  "from smbus2 import SMBus; SMBus(1).write_i2c_block_data(0x40, 0x06, [0, 0, 200, 0])" \
  2>"$dir/late.err" || fail "fd: a new task was not served after the exhaustion"
stop_writer fd
stop_monitor fd
echo "descriptor exhaustion: ok ($(cat "$dir/idle.out"), $(count accept-failed "$dir/fd.jsonl") accept-failed and $(count hello-timeout "$dir/fd.jsonl") hello-timeout lines; the task kept being served)"

# The per-uid cap: idle connections of another uid stop at the cap; the task is served.
if id nobody >/dev/null 2>&1 && command -v setpriv >/dev/null; then
  start_monitor cap --audit "$dir/cap.jsonl" --client-uid "$(id -u nobody)" \
    --max-connections-per-uid 8 --hello-timeout-ms 0
  chmod 666 "$dir/cap.sock"  # the monitor makes it 0660: let uid nobody reach it
  setpriv --reuid nobody --regid nogroup --clear-groups /usr/bin/python3 \
    "$scripts/hostile_client.py" idle "$dir/cap.sock" 50 2 >"$dir/capidle.out" &
  capped=$!
  sleep 0.5
  start_writer cap "$dir/cap.sock" 0.005
  wait_ok "$dir/cap.out" 20 || fail "cap: the task was not served while another uid held its cap"
  wait $capped
  stop_writer cap
  stop_monitor cap
  refused=$(grep -acF "over the cap of 8" "$dir/cap.jsonl")
  grep -q "8 still open" "$dir/capidle.out" || fail "cap: $(cat "$dir/capidle.out")"
  ((refused >= 1)) || fail "cap: nothing refused over the cap"
  echo "per-uid cap: ok ($refused connection(s) of uid nobody refused over the cap of 8)"
fi
echo "ok"
