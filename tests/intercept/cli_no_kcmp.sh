#!/usr/bin/env bash
# `contego run` on a kernel without kcmp (CONFIG_KCMP unset), played by a
# seccomp filter that answers kcmp with ENOSYS: the supervisor cannot prove
# that a cached bus descriptor is still the bus's, so every call takes the
# checked way (the process's liveness decides). Commands are still checked
# and served, and a new process under a dead one's number still holds none
# of its bus descriptors. Both with the embedded monitor and with
# `contego run --socket` (the monitor daemon runs unfiltered: it never
# calls kcmp).
# Usage: cli_no_kcmp.sh CONTEGO POLICIES_DIR SCRIPTS_DIR WITHOUT_KCMP ATTACK_PID_REUSE
set -uo pipefail
contego="$1" policies="$2" scripts="$3" without_kcmp="$4" attack="$5"
# shellcheck source=tests/intercept/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/cli_common.sh"
sock="$dir/monitor.sock"
run() {  # NAME PROGRAM...: the gripper task under arm.policy, kcmp refused
  local name="$1"
  shift
  if [[ $name == socket-* ]]; then
    "$without_kcmp" "$contego" run --socket "$sock" --task gripper -- "$@" \
      >"$dir/$name.out" 2>"$dir/$name.err"
  else
    "$without_kcmp" "$contego" run --policy "$policies/arm.policy" --task gripper \
      --virtual-bus 1 --audit "$dir/$name.jsonl" -- "$@" >"$dir/$name.out" 2>"$dir/$name.err"
  fi
}
decided() {  # LOG BYTES DECISION: the log holds a decision on these bytes
  grep -aF "\"bytes\":\"$2\"" "$1" | grep -qF "\"decision\":\"$3\""
}
grip() {  # NAME LOG: gripper_smbus2.py's pulse allowed, its PRE_SCALE write dropped
  run "$1" /usr/bin/python3 "$scripts/gripper_smbus2.py" || fail "$1: gripper_smbus2.py: exit $?"
  grep -q "pulse sent" "$dir/$1.out" || fail "$1: the pulse was not sent"
  grep -q "prescale written" "$dir/$1.out" || fail "$1: the PRE_SCALE write was not answered"
  for _ in $(seq 50); do decided "$2" "fe 03" ignore && break; sleep 0.1; done
  decided "$2" "1a 00 00 a4 01" allow || fail "$1: the pulse was not checked and allowed"
  decided "$2" "fe 03" ignore || fail "$1: the PRE_SCALE write was not dropped"
  echo "$1: commands checked without kcmp: ok"
}
reuse() {  # NAME: a new process under a dead one's number holds none of its descriptors
  run "$1" "$attack" || fail "$1: attack_pid_reuse: exit $?"
  if grep -q "reuse-skipped" "$dir/$1.out"; then
    echo "$1: pid reuse skipped: $(tr '\n' ' ' <"$dir/$1.out")"
    return
  fi
  grep -qx "reuse-same-number 0 0" "$dir/$1.out" || fail "$1: no process under the dead one's number"
  grep -qx "reuse-slave 9" "$dir/$1.out" ||
    fail "$1: I2C_SLAVE on the dead one's descriptor did not get EBADF"
  grep -qx "reuse-write -1 9" "$dir/$1.out" ||
    fail "$1: the write on the dead one's descriptor did not get EBADF"
  echo "$1: a dead process's descriptors stay its own without kcmp: ok"
}

"$without_kcmp" true
[[ $? -eq 0 ]] || { printf "skipped: cannot refuse kcmp here (see without_kcmp's message)\nok\n"; exit 0; }

grip embedded "$dir/embedded.jsonl"

"$contego" monitor --policy "$policies/arm.policy" --virtual-bus 1 --socket "$sock" \
  --audit "$dir/monitor.jsonl" >"$dir/monitor.out" 2>"$dir/monitor.err" &
monitor_pid=$!
wait_for_socket "$sock" || fail "the monitor did not start"
grip socket-grip "$dir/monitor.jsonl"

if [[ $(id -u) -ne 0 ]]; then
  printf "pid reuse skipped: choosing a process id needs root\nok\n"
  exit 0
fi
reuse embedded-reuse
reuse socket-reuse
kill -0 "$monitor_pid" || fail "the monitor stopped"
stop_monitor || fail "the monitor exited $? on SIGTERM"
echo "ok"
