#!/usr/bin/env bash
# Days of audit (issue 40, docs/performance.md "Days of audit"): audit_days
# writes DAYS simulated days of the rover's decisions through the real
# monitor, rotating at MAX_BYTES; then `contego audit` verifies every file
# as one chain, oldest first, and the time it takes is printed beside the
# writer's figures.
# Usage: audit_days.sh AUDIT_DAYS CONTEGO [DAYS (1)] [MAX_BYTES (100 MB)] [RECORDS (0: DAYS' worth)]
set -euo pipefail
writer="$1" contego="$2" days="${3:-1}" max="${4:-104857600}" records="${5:-0}"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
"$writer" "$dir" "$days" "$max" "$records"
mapfile -t files < <(cd "$dir" && ls audit.jsonl* | sed 's/^audit\.jsonl\.\?//' | sort -rn |
  sed 's/^\([0-9][0-9]*\)$/audit.jsonl.\1/; s/^$/audit.jsonl/')
bytes=$(cat "${files[@]/#/$dir/}" | wc -c)
t0=$(date +%s.%N)
"$contego" audit "${files[@]/#/$dir/}" >"$dir/verify.out" 2>&1 || { tail -n 5 "$dir/verify.out"; exit 1; }
t1=$(date +%s.%N)
tail -n 1 "$dir/verify.out" | cut -c1-60
python3 - "$t0" "$t1" "$bytes" "${#files[@]}" <<'PY'
import sys
t0, t1, size, n = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
s = t1 - t0
print(f"  contego audit          {n} files, {size / 1e6:.1f} MB verified as one chain in {s:.1f} s ({size / 1e6 / s:.0f} MB/s)")
PY
echo ok
