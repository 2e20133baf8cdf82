#!/usr/bin/env bash
# `contego run` on a kernel without kcmp (CONFIG_KCMP unset), played by a
# seccomp filter that answers kcmp with ENOSYS: the supervisor cannot prove
# that a cached bus descriptor is still the bus's, so every call takes the
# checked way (the process's liveness decides). Commands are still checked
# and served, and a new process under a dead one's number still holds none
# of its bus descriptors.
# Usage: cli_no_kcmp.sh CONTEGO POLICIES_DIR SCRIPTS_DIR WITHOUT_KCMP ATTACK_PID_REUSE
set -uo pipefail
contego="$1" policies="$2" scripts="$3" without_kcmp="$4" attack="$5"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; for f in "$dir"/*; do [[ -f "$f" ]] && { echo "--- $f"; tail -n 20 "$f" | tr -d '\0'; }; done; exit 1; }
run() {  # NAME PROGRAM...: the gripper task under arm.policy, kcmp refused
  "$without_kcmp" "$contego" run --policy "$policies/arm.policy" --task gripper --virtual-bus 1 \
    --audit "$dir/$1.jsonl" -- "${@:2}" >"$dir/$1.out" 2>"$dir/$1.err"
}

"$without_kcmp" true
[[ $? -eq 0 ]] || { printf "skipped: cannot refuse kcmp here (see without_kcmp's message)\nok\n"; exit 0; }

run grip /usr/bin/python3 "$scripts/gripper_smbus2.py" || fail "gripper_smbus2.py: exit $?"
grep -q "pulse sent" "$dir/grip.out" || fail "the pulse was not sent"
grep -aF '"bytes":"1a 00 00 a4 01"' "$dir/grip.jsonl" | grep -qF '"decision":"allow"' ||
  fail "the pulse was not checked and allowed"
grep -q "prescale written" "$dir/grip.out" || fail "the PRE_SCALE write was not answered"
grep -aF '"bytes":"fe 03"' "$dir/grip.jsonl" | grep -qF '"decision":"ignore"' ||
  fail "the PRE_SCALE write was not dropped"
echo "commands checked without kcmp: ok"

if [[ $(id -u) -ne 0 ]]; then
  printf "pid reuse skipped: choosing a process id needs root\nok\n"
  exit 0
fi
run reuse "$attack" || fail "attack_pid_reuse: exit $?"
if grep -q "reuse-skipped" "$dir/reuse.out"; then
  printf "pid reuse skipped: %s\nok\n" "$(cat "$dir/reuse.out" | tr '\n' ' ')"
  exit 0
fi
grep -qx "reuse-same-number 0 0" "$dir/reuse.out" || fail "no process under the dead one's number"
grep -qx "reuse-slave 9" "$dir/reuse.out" || fail "I2C_SLAVE on the dead one's descriptor did not get EBADF"
grep -qx "reuse-write -1 9" "$dir/reuse.out" || fail "the write on the dead one's descriptor did not get EBADF"
echo "a dead process's descriptors stay its own without kcmp: ok"
echo "ok"
