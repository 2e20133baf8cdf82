#!/usr/bin/env bash
# A bundle's host side (`contego check --emit-bundle --budget-factor N --bus
# N=PATH`): it goes into the bundle (and under its signature), the monitor
# takes it without the options, a command line that contradicts it is
# refused with both values named, and a reload keeps it.
# Usage: bundle_host_side.sh CONTEGO POLICIES_DIR
set -euo pipefail
contego="$1" policies="$2"
dir="$(mktemp -d)"
mon=""
cleanup() {
  [ -n "$mon" ] && kill "$mon" 2>/dev/null && wait "$mon" 2>/dev/null
  rm -rf "$dir"
}
trap cleanup EXIT
fail() { echo "FAIL: $*"; cat "$dir/out" 2>/dev/null; exit 1; }
arm="$policies/arm.policy"

"$contego" check "$arm" --emit-bundle "$dir/fixed.bundle" --budget-factor 0 --bus 1=/dev/i2c-9 \
  >/dev/null 2>"$dir/out" || fail "check --emit-bundle with a host side: exit $?"
python3 - "$dir/fixed.bundle" <<'PY' || fail "the bundle's host side"
import json, sys
b = json.load(open(sys.argv[1]))
assert b["budget_factor"] == 0 and b["buses"] == {"1": "/dev/i2c-9"}, b
PY
if "$contego" check "$arm" --budget-factor 2 >"$dir/out" 2>&1; then fail "--budget-factor without a bundle"; fi
grep -q "give --emit-bundle" "$dir/out" || fail "no reason for --budget-factor without a bundle"
if "$contego" check "$arm" --emit-bundle "$dir/x" --bus 1=i2c >"$dir/out" 2>&1; then fail "a bad --bus"; fi

# No --bus: the monitor opens the bundle's adapter (here one that does not exist).
if "$contego" monitor --bundle "$dir/fixed.bundle" --socket "$dir/m.sock" --audit "$dir/a.jsonl" \
    >"$dir/out" 2>&1; then
  fail "the monitor started on a bus that does not exist"
fi
grep -q "/dev/i2c-9" "$dir/out" || fail "the monitor did not use the bundle's adapter"
# A command line that contradicts the bundle.
if "$contego" monitor --bundle "$dir/fixed.bundle" --virtual-bus 1 --socket "$dir/m.sock" \
    --audit "$dir/a.jsonl" >"$dir/out" 2>&1; then
  fail "--virtual-bus over the bundle's bus"
fi
grep -q "the bundle .* says bus 1 is /dev/i2c-9" "$dir/out" || fail "no reason for --virtual-bus"
if "$contego" monitor --bundle "$dir/fixed.bundle" --bus 1=/dev/i2c-3 --socket "$dir/m.sock" \
    --audit "$dir/a.jsonl" >"$dir/out" 2>&1; then
  fail "--bus over the bundle's bus"
fi
grep -q -- "--bus /dev/i2c-3: the bundle .* says bus 1 is /dev/i2c-9" "$dir/out" || fail "no reason for --bus"

# A bundle fixing the budget factor only: the monitor takes it; repeating it
# is fine, another value is refused.
"$contego" check "$arm" --emit-bundle "$dir/factor.bundle" --budget-factor 0 >/dev/null 2>&1
if "$contego" monitor --bundle "$dir/factor.bundle" --virtual-bus 1 --budget-factor 4 \
    --socket "$dir/m.sock" --audit "$dir/a.jsonl" >"$dir/out" 2>&1; then
  fail "--budget-factor 4 over the bundle's 0"
fi
grep -q -- "--budget-factor 4: the bundle .* says 0" "$dir/out" || fail "no reason for --budget-factor"
"$contego" monitor --bundle "$dir/factor.bundle" --virtual-bus 1 --budget-factor 0 \
  --socket "$dir/m.sock" --audit "$dir/a.jsonl" 2>"$dir/mon.err" &
mon=$!
for _ in $(seq 100); do [ -S "$dir/m.sock" ] && break; sleep 0.1; done
[ -S "$dir/m.sock" ] || { cat "$dir/mon.err"; fail "the monitor did not start"; }
"$contego" status --socket "$dir/m.sock" --json >"$dir/out" || fail "status exit $?"
python3 -c 'import json, sys; s = json.load(open(sys.argv[1])); assert s["budget_factor"] == 0, s["budget_factor"]' \
  "$dir/out" || fail "the status does not show the bundle's budget factor 0"
# A reload keeps the host side: another budget factor is refused.
"$contego" check "$arm" --emit-bundle "$dir/other.bundle" --budget-factor 3 >/dev/null 2>&1
if "$contego" reload --bundle "$dir/other.bundle" --socket "$dir/m.sock" >"$dir/out" 2>&1; then
  fail "a reload changed the budget factor"
fi
grep -q "budget factor is 3, the running monitor's 0" "$dir/out" || fail "no reason for the reload's refusal"
"$contego" reload --bundle "$dir/factor.bundle" --socket "$dir/m.sock" >"$dir/out" 2>&1 ||
  fail "a reload with the same host side: exit $?"
echo "ok"
