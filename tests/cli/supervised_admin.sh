#!/usr/bin/env bash
# A supervised program and its descendants never act on the monitor, whatever
# their uid (docs/threat-model.md): here the program runs under the monitor's
# own uid, which `contego reset` accepts from anyone else, and tries
#  - `contego reset DEVICE` itself (its own connection, no hello);
#  - the same from a grandchild that double-forked into a new session after
#    the program exited (orphaned: `contego run` adopts it as a subreaper);
#  - a reset on its supervisor's task session (the wire request sent on a
#    connection bound to the task).
# Each is refused with the reason and audited; a reset by the operator (same
# uid, not supervised) is granted; the audit chain verifies.
# Usage: supervised_admin.sh CONTEGO POLICIES_DIR
set -euo pipefail
contego="$1" policies="$2"
dir="$(mktemp -d)"
mon=""
cleanup() { [ -n "$mon" ] && kill "$mon" 2>/dev/null && wait "$mon" 2>/dev/null; rm -rf "$dir"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; [ -f "$dir/audit.jsonl" ] && tail -n 5 "$dir/audit.jsonl"; exit 1; }

"$contego" monitor --policy "$policies/rover.policy" --virtual-bus 1 --socket "$dir/m.sock" \
  --audit "$dir/audit.jsonl" --client-uid "$(id -u)" 2>"$dir/mon.err" &
mon=$!
for _ in $(seq 100); do [ -S "$dir/m.sock" ] && break; sleep 0.1; done
[ -S "$dir/m.sock" ] || { cat "$dir/mon.err"; fail "the monitor did not start"; }

# 1. The program itself.
if "$contego" run --socket "$dir/m.sock" --task follower -- \
    "$contego" reset gopigo --socket "$dir/m.sock" >"$dir/p1.out" 2>&1; then
  cat "$dir/p1.out"; fail "the supervised program's reset was granted"
fi
grep -q "supervised by contego" "$dir/p1.out" || { cat "$dir/p1.out"; fail "no reason given (1)"; }

# 2. A grandchild in a session of its own, after the program has gone.
"$contego" run --socket "$dir/m.sock" --task follower -- /bin/sh -c "
  setsid /bin/sh -c 'sleep 0.5; \"$contego\" reset gopigo --socket \"$dir/m.sock\" >\"$dir/p2.out\" 2>&1; echo rc=\$? >>\"$dir/p2.out\"' &
  exit 0" >"$dir/run2.out" 2>&1 || true
for _ in $(seq 100); do grep -q '^rc=' "$dir/p2.out" 2>/dev/null && break; sleep 0.1; done
grep -q '^rc=0' "$dir/p2.out" && { cat "$dir/p2.out"; fail "the double-forked grandchild's reset was granted"; }
grep -q "supervised by contego" "$dir/p2.out" || { cat "$dir/p2.out" "$dir/run2.out"; fail "no reason given (2)"; }

# 3. The operator, same uid, outside any supervision: granted.
"$contego" reset gopigo --socket "$dir/m.sock" | grep -q "gopigo was not latched" ||
  fail "the operator's reset was refused"

n=$(grep -c '"kind":"reset-refused"' "$dir/audit.jsonl" || true)
[ "$n" -ge 2 ] || fail "expected 2 reset-refused events, found $n"
kill "$mon"
wait "$mon" || true
mon=""
"$contego" audit "$dir/audit.jsonl" | grep -q "chain intact" || fail "audit chain"
echo "ok"
