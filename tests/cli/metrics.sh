#!/usr/bin/env bash
# `contego monitor --metrics-file`: the Prometheus text format, written
# atomically at start and every interval (node_exporter's textfile
# collector reads it); a live task's decisions appear in it; a file the
# monitor cannot write refuses the start, naming it.
# Usage: metrics.sh CONTEGO POLICIES_DIR
set -euo pipefail
contego="$1" policies="$2"
dir="$(mktemp -d)"
mon=""
cleanup() { [ -n "$mon" ] && kill "$mon" 2>/dev/null && wait "$mon" 2>/dev/null; rm -rf "$dir"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; cat "$dir/m.prom" 2>/dev/null; exit 1; }

if "$contego" monitor --policy "$policies/rover.policy" --virtual-bus 1 --socket "$dir/x.sock" \
    --metrics-file /proc/contego-nowhere/contego.prom 2>"$dir/err"; then
  fail "the monitor started with an unwritable metrics file"
fi
grep -q "cannot write the metrics file /proc/contego-nowhere/contego.prom.tmp" "$dir/err" ||
  { cat "$dir/err"; fail "no reason for the unwritable metrics file"; }

"$contego" monitor --policy "$policies/rover.policy" --virtual-bus 1 --socket "$dir/m.sock" \
  --audit "$dir/audit.jsonl" --metrics-file "$dir/m.prom" --metrics-interval 1 2>"$dir/mon.err" &
mon=$!
# The socket is bound a moment before the first metrics file is written (a
# client that connects meanwhile waits in the backlog): wait for both.
for _ in $(seq 100); do [ -S "$dir/m.sock" ] && [ -f "$dir/m.prom" ] && break; sleep 0.1; done
[ -S "$dir/m.sock" ] || { cat "$dir/mon.err"; fail "the monitor did not start"; }
grep -q '^contego_info{policy=".*rover.policy (SHA-256 [0-9a-f]*)",image_sha256="[0-9a-f]\{64\}",complain="0"} 1$' "$dir/m.prom" ||
  fail "no contego_info at start"
"$contego" run --socket "$dir/m.sock" --task follower -- /bin/sh -c \
  "i2cset -y 1 0x08 0x01 0x46 i; i2cset -y 1 0x08 0x01 0x46 i" >/dev/null 2>&1 || true
for _ in $(seq 40); do
  grep -qE '^contego_decisions_total\{task="follower",verdict="[a-z]+"\} [1-9]' "$dir/m.prom" && break
  sleep 0.1
done
grep -qE '^contego_decisions_total\{task="follower",verdict="[a-z]+"\} [1-9]' "$dir/m.prom" ||
  fail "the follower's decisions are not in the metrics file"
# Every sample line is `name{labels} value`, every family has HELP and TYPE.
python3 - "$dir/m.prom" <<'PY' || fail "not the text exposition format"
import re, sys
typed = set()
for line in open(sys.argv[1]):
    line = line.rstrip("\n")
    if line.startswith("# TYPE "):
        name, kind = line.split()[2:4]
        assert kind in ("counter", "gauge", "histogram"), line
        typed.add(name)
    elif line.startswith("# HELP ") or not line:
        continue
    else:
        m = re.fullmatch(r'([a-z_]+)(\{[^}]*\})? ([0-9]+(\.[0-9]+)?)', line)
        base = re.sub(r'_(bucket|sum|count)$', '', m.group(1)) if m else ""
        assert m and (m.group(1) in typed or base in typed), line
PY
# The cost of deciding: a histogram whose +Inf bucket counts every decided transfer.
grep -qE '^contego_check_duration_seconds_bucket\{le="\+Inf"\} [1-9][0-9]*$' "$dir/m.prom" &&
  grep -qE '^contego_check_duration_seconds_bucket\{le="1e-06"\} [0-9]+$' "$dir/m.prom" &&
  [ "$(sed -n 's/^contego_check_duration_seconds_count //p' "$dir/m.prom")" = \
    "$(sed -n 's/^contego_check_duration_seconds_bucket{le="+Inf"} //p' "$dir/m.prom")" ] ||
  fail "no check-cost histogram"
grep -qE '^contego_device_sample_age_seconds\{device="line"\} [0-9]+\.[0-9]{3}$' "$dir/m.prom" ||
  fail "no sample age of the line sensor"
[ ! -e "$dir/m.prom.tmp" ] || fail "a temporary file was left"
grep -q 'contego_device_unavailable{' "$dir/m.prom" && fail "a device unavailable in a start that was not degraded"
kill "$mon"
wait "$mon" || true
mon=""

# A degraded start (the GoPiGo and the line sensor where the virtual bus has
# nothing): the metrics say which device is unavailable and why, every
# interval, and the monitor keeps serving.
sed -e 's/^device gopigo : gopigo2 at i2c-1 0x08/device gopigo : gopigo2 at i2c-1 0x09/' \
  -e 's/^device line : line_follower at i2c-1 0x06/device line : line_follower at i2c-1 0x07/' \
  "$policies/rover.policy" >"$dir/away.policy"
rm -f "$dir/m.prom"
"$contego" monitor --policy "$dir/away.policy" --virtual-bus 1 --socket "$dir/d.sock" \
  --audit "$dir/d.jsonl" --allow-degraded --metrics-file "$dir/m.prom" --metrics-interval 1 \
  2>"$dir/mon.err" &
mon=$!
for _ in $(seq 100); do [ -S "$dir/d.sock" ] && [ -f "$dir/m.prom" ] && break; sleep 0.1; done
[ -f "$dir/m.prom" ] || { cat "$dir/mon.err"; fail "the degraded monitor wrote no metrics"; }
sleep 1.5  # a periodic write too
kill -0 "$mon" 2>/dev/null || { cat "$dir/mon.err"; fail "the degraded monitor died writing its metrics"; }
grep -qx 'contego_device_unavailable{device="line",what="reading"} 1' "$dir/m.prom" &&
  grep -qx 'contego_device_unavailable{device="gopigo",what="safe_state"} 1' "$dir/m.prom" ||
  fail "the unavailable devices are not in the metrics"
grep -q 'contego_device_sample_age_seconds{device="line"}' "$dir/m.prom" &&
  fail "a sample age for a sensor with no reading"
kill "$mon"
wait "$mon" || true
mon=""
echo "ok"
