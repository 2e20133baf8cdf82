#!/usr/bin/env bash
# `contego monitor` and `contego run` from the command line: the --bus forms
# and their errors, and a start that fails closed (exit 2, a message naming
# the device, its bus and address) unless --allow-degraded.
# Usage: cli_start.sh CONTEGO POLICIES_DIR
set -uo pipefail
contego="$1" policies="$2"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; [[ -f "$dir/err" ]] && cat "$dir/err"; exit 1; }
# expect CODE TEXT -- ARGS...: contego ARGS exits CODE and prints TEXT (stderr or stdout).
expect() {
  local code="$1" text="$2"
  shift 3
  "$contego" "$@" >"$dir/out" 2>"$dir/err"
  local got=$?
  [[ $got -eq $code ]] || fail "contego $*: exit $got, expected $code"
  grep -qF -- "$text" "$dir/err" "$dir/out" || fail "contego $*: no '$text'"
}
rover="$policies/rover.policy"

# --bus: N=PATH and /dev/i2c-N parse; a bare number or a bad one is named.
for cmd in monitor "run --task follower"; do
  tail=(); [[ $cmd == run* ]] && tail=(-- /bin/true)
  # shellcheck disable=SC2086
  expect 0 "parse-only: contego ${cmd%% *}: ok" -- --parse-only $cmd --policy "$rover" \
    --bus 1=/dev/i2c-1 --bus /dev/i2c-7 "${tail[@]}"
  # shellcheck disable=SC2086
  expect 105 "--bus '1': expected N=PATH (e.g. 1=/dev/i2c-1) or /dev/i2c-N" -- $cmd \
    --policy "$rover" --bus 1 "${tail[@]}"
  # shellcheck disable=SC2086
  expect 105 "--bus 'x=/dev/i2c-1': the bus number 'x' is not 0..255" -- $cmd \
    --policy "$rover" --bus x=/dev/i2c-1 "${tail[@]}"
  # shellcheck disable=SC2086
  expect 2 "--virtual-bus 1: bus 1 is already the adapter /dev/i2c-1" -- $cmd \
    --policy "$rover" --bus 1=/dev/i2c-1 --virtual-bus 1 "${tail[@]}"
  # shellcheck disable=SC2086
  expect 2 "--bus '1=/dev/i2c-2': bus 1 is already /dev/i2c-1" -- $cmd \
    --policy "$rover" --bus 1=/dev/i2c-1 --bus 1=/dev/i2c-2 "${tail[@]}"
done
expect 2 "bus 1: " -- monitor --policy "$rover" --bus 1=/nonexistent/i2c-1 --socket "$dir/s"

# A policy device without an adapter for its bus: refused, nothing started.
expect 2 "device gopigo at i2c-1 0x08: no adapter for bus 1 (give --bus 1=/dev/i2c-1 or --virtual-bus 1)" \
  -- run --policy "$rover" --task follower --virtual-bus 2 --audit "$dir/a1" -- /bin/echo RAN
grep -q RAN "$dir/out" && fail "the program ran"
grep -q '"kind":"start-refused"' "$dir/a1" || fail "no start-refused event"
expect 2 "device line at i2c-1 0x06: no adapter for bus 1" \
  -- monitor --policy "$rover" --virtual-bus 2 --socket "$dir/s" --audit "$dir/a2"
[[ -e "$dir/s" ]] && fail "the monitor bound its socket"

# Devices that do not answer (tank.policy's devices are not on the virtual bus).
expect 2 "device tank at i2c-1 0x48 does not answer: an SMBus quick write on a virtual bus failed with ENXIO" \
  -- run --policy "$policies/tank.policy" --task monitor --virtual-bus 1 -- /bin/echo RAN
grep -q "device buzzer at i2c-1 0x20 does not answer" "$dir/err" || fail "buzzer not named"
grep -q RAN "$dir/out" && fail "the program ran"
# pump.policy's encoder at 0x51 is probed with a read, as i2cdetect does.
expect 2 "device encoder at i2c-1 0x51 does not answer: a one-byte read on a virtual bus failed with ENXIO" \
  -- monitor --policy "$policies/pump.policy" --virtual-bus 1 --socket "$dir/s"

# --allow-degraded: starts, says so, audits it.
task=$(sed -n 's/^task \([a-z_]*\).*/\1/p' "$policies/tank.policy" | head -1)
expect 0 "--allow-degraded: starting although device tank at i2c-1 0x48 does not answer" \
  -- run --policy "$policies/tank.policy" --task "$task" --virtual-bus 1 --allow-degraded \
  --audit "$dir/a3" -- /bin/echo RAN
grep -q RAN "$dir/out" || fail "--allow-degraded: the program did not run"
grep -q '"kind":"degraded-start"' "$dir/a3" || fail "no degraded-start event"

# An adapter that no device uses: a warning, and the start goes on.
expect 0 "warning: bus 2 (a virtual bus): no device of the policy is on it" \
  -- run --policy "$rover" --task follower --virtual-bus 1 --virtual-bus 2 -- /bin/echo RAN
grep -q RAN "$dir/out" || fail "unused bus: the program did not run"

# --cpu N: the program (and what it starts) runs on CPU N only; a CPU this
# process may not use is refused before the program runs.
cpus=$(python3 -c 'import os; print(" ".join(map(str, sorted(os.sched_getaffinity(0)))))')
cpu=${cpus##* }
expect 0 "[$cpu]" -- run --policy "$rover" --task follower --virtual-bus 1 --audit "$dir/a4" \
  --cpu "$cpu" -- python3 -c 'import os; print(sorted(os.sched_getaffinity(0)))'
expect 2 "CPU 1023 is not one this process may run on" -- run --policy "$rover" \
  --task follower --virtual-bus 1 --audit "$dir/a5" --cpu 1023 -- /bin/echo RAN
grep -q RAN "$dir/out" && fail "--cpu 1023: the program ran"
# --rt without --cpu on several CPUs: a note says what it costs; with --cpu, none.
if [[ "$cpus" == *" "* ]]; then
  expect 0 "give --cpu N to keep them on one" -- run --policy "$rover" --task follower \
    --virtual-bus 1 --audit "$dir/a6" --rt -- /bin/true
fi
"$contego" run --policy "$rover" --task follower --virtual-bus 1 --audit "$dir/a7" --rt \
  --cpu "$cpu" -- /bin/true 2>"$dir/err" || fail "--rt --cpu $cpu: exit $?"
grep -q "give --cpu" "$dir/err" && fail "--rt --cpu: the note was printed"
echo "ok"
