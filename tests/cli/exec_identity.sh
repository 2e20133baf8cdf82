#!/usr/bin/env bash
# A task bound by `exe` stays bound after the program executes another file:
# `contego run --socket` sees the execve and asks the monitor to check the
# binding again before the new image's first call is answered. Executing the
# bound file again goes on (an `identity` record); executing another file
# ends the program (exit 4, an `identity-refused` record) before it acts.
# Usage: exec_identity.sh CONTEGO
set -euo pipefail
contego="$1"
dir="$(mktemp -d)"
chmod 755 "$dir"
mon=""
cleanup() { [ -n "$mon" ] && kill "$mon" 2>/dev/null && wait "$mon" 2>/dev/null; rm -rf "$dir"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; grep -a '"kind":"identity' "$dir/audit.jsonl" | cut -c1-300 || true; exit 1; }
sh_exe=$(readlink -f /bin/sh)
cat >"$dir/exec.policy" <<POLICY
device servos : pca9685 at i2c-1 0x40 { safe mode2(outdrv=1) }
task worker {
  exe "$sh_exe"
  period 200ms; deadline 200ms; wcet 20ms; priority 1
  actuations 3
}
allow worker -> servos
POLICY
"$contego" monitor --policy "$dir/exec.policy" --virtual-bus 1 --socket "$dir/m.sock" \
  --audit "$dir/audit.jsonl" --client-uid "$(id -u)" 2>"$dir/mon.err" &
mon=$!
for _ in $(seq 100); do [ -S "$dir/m.sock" ] && break; sleep 0.1; done
[ -S "$dir/m.sock" ] || { cat "$dir/mon.err"; fail "the monitor did not start"; }

# The bound shell executes itself again: allowed, recorded.
"$contego" run --socket "$dir/m.sock" --task worker -- "$sh_exe" -c "exec $sh_exe -c 'echo again'" \
  >"$dir/same.out" 2>&1 || { cat "$dir/same.out"; fail "exec of the bound file was refused"; }
grep -q '^again$' "$dir/same.out" || { cat "$dir/same.out"; fail "the re-executed shell did not run"; }
grep -q '"kind":"identity"' "$dir/audit.jsonl" || fail "no identity record for the exec"

# The bound shell executes another file: ended before it runs, exit 4.
rc=0
"$contego" run --socket "$dir/m.sock" --task worker -- "$sh_exe" -c "exec /bin/echo escaped" \
  >"$dir/other.out" 2>&1 || rc=$?
[ "$rc" = 4 ] || { cat "$dir/other.out"; fail "exec of another file: exit $rc, expected 4"; }
grep -q '^escaped$' "$dir/other.out" && fail "the other file ran"
grep -q "may not act for task 'worker'" "$dir/other.out" || { cat "$dir/other.out"; fail "no reason"; }
grep -q '"kind":"identity-refused"' "$dir/audit.jsonl" || fail "no identity-refused record"
kill "$mon"
wait "$mon" || true
mon=""
"$contego" audit "$dir/audit.jsonl" | grep -q "chain intact" || fail "audit chain"
echo "ok"
