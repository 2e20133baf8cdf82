#!/usr/bin/env bash
# `contego doctor` on this machine: the kernel line, a line (with its fix)
# for the buses whatever they are, the summary; a stale monitor socket (the
# file left, nobody listening) is a problem, with its fix, and exit 1. The
# test bed's scenario 00 runs it where an adapter exists.
# Usage: doctor.sh CONTEGO
set -euo pipefail
contego="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; cat "$dir/out"; exit 1; }
"$contego" doctor --socket "$dir/none.sock" >"$dir/out" 2>&1 || true
grep -q '^\[ ok \] kernel .*seccomp user notification' "$dir/out" || fail "no kernel line"
grep -qE 'i2c-dev is loaded|neither i2c-dev nor contego.ko' "$dir/out" || fail "no i2c-dev line"
grep -q "no monitor socket at $dir/none.sock" "$dir/out" || fail "no monitor line"
grep -qE '^[0-9]+ problem\(s\), [0-9]+ warning\(s\)$' "$dir/out" || fail "no summary"
python3 -c 'import socket, sys; s = socket.socket(socket.AF_UNIX); s.bind(sys.argv[1]); s.close()' "$dir/stale.sock"
rc=0
"$contego" doctor --socket "$dir/stale.sock" >"$dir/out" 2>&1 || rc=$?
[ "$rc" = 1 ] || fail "a stale monitor socket: exit $rc, expected 1"
grep -q "^\[FAIL\] $dir/stale.sock exists but no monitor answers" "$dir/out" || fail "no stale-socket line"
grep -q "fix: systemctl restart contego-monitor" "$dir/out" || fail "no fix for the stale socket"
echo "ok"
