#!/usr/bin/env bash
# `contego monitor --image` enforces only a pinned image (by --image-sha256,
# or equal to what --policy compiles to) and refuses others with the hashes;
# `contego reset DEVICE` reaches the running monitor, is audited, and is
# refused (and audited) for a uid that is neither root nor the monitor's.
# Usage: image_reset.sh CONTEGO POLICIES_DIR
set -euo pipefail
contego="$1" policies="$2"
dir="$(mktemp -d)"
chmod 755 "$dir"
mon=""
cleanup() { [ -n "$mon" ] && kill "$mon" 2>/dev/null && wait "$mon" 2>/dev/null; rm -rf "$dir"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }

"$contego" check --strict "$policies/rover.policy" --emit "$dir/rover.img" 2>"$dir/check.err" >/dev/null
hash="$(sed -n 's/.*SHA-256 \([0-9a-f]\{64\}\).*/\1/p' "$dir/check.err")"
[ -n "$hash" ] || fail "check --emit printed no SHA-256"

expect_refused() {  # PATTERN ARGS...
  local pattern="$1"
  shift
  if "$contego" monitor --virtual-bus 1 --socket "$dir/x.sock" "$@" 2>"$dir/refused.err"; then
    fail "monitor started with $*"
  fi
  grep -q "$pattern" "$dir/refused.err" || { cat "$dir/refused.err"; fail "no '$pattern'"; }
}
expect_refused "expects 0000: refusing it" --image "$dir/rover.img" --image-sha256 0000
expect_refused "is not pinned" --image "$dir/rover.img"
expect_refused "is not the image policy .*tank.policy compiles to" \
  --image "$dir/rover.img" --policy "$policies/tank.policy"
printf 'not an image' >"$dir/bad.img"
expect_refused "shorter than the 32-byte header" --image "$dir/bad.img" \
  --image-sha256 "$(sha256sum "$dir/bad.img" | cut -c1-64)"

"$contego" monitor --image "$dir/rover.img" --image-sha256 "$hash" --virtual-bus 1 \
  --socket "$dir/m.sock" --audit "$dir/audit.jsonl" --client-uid 65534 2>"$dir/mon.err" &
mon=$!
for _ in $(seq 50); do [ -S "$dir/m.sock" ] && break; sleep 0.1; done
[ -S "$dir/m.sock" ] || { cat "$dir/mon.err"; fail "the monitor did not start"; }
grep -q "SHA-256 $hash" "$dir/audit.jsonl" || fail "the start event does not name the image's hash"

"$contego" reset gopigo --socket "$dir/m.sock" | grep -q "gopigo was not latched" ||
  fail "reset by the monitor's uid"
if "$contego" reset nosuch --socket "$dir/m.sock" 2>"$dir/r.err"; then fail "unknown device"; fi
grep -q "no device 'nosuch'" "$dir/r.err" || fail "unknown device not named"
if [ "$(id -u)" = 0 ]; then
  chmod o+rw "$dir/m.sock"  # let uid 65534 reach it (the monitor makes it owner/group only)
  if setpriv --reuid 65534 --regid 65534 --clear-groups \
      "$contego" reset gopigo --socket "$dir/m.sock" 2>"$dir/r2.err"; then
    fail "reset by uid 65534 was granted"
  fi
  grep -q "only root or the monitor's uid" "$dir/r2.err" || { cat "$dir/r2.err"; fail "refusal"; }
  grep -q '"kind":"reset-refused"' "$dir/audit.jsonl" || fail "no reset-refused event"
else
  echo "skipped the other-uid refusal: needs root to switch uid"
fi
grep -q '(gopigo) reset by uid.*"kind":"reset"' "$dir/audit.jsonl" || fail "no reset event"
kill "$mon"
wait "$mon" || true
mon=""
"$contego" audit "$dir/audit.jsonl" | grep -q "chain intact" || fail "audit chain"
echo "ok"
