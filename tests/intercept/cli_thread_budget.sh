#!/usr/bin/env bash
# `contego run`: a task whose second thread sleeps half a period gets exactly
# its declared budget per period (3 writes per 200 ms job), judged from the
# audit log: every job has exactly 3 writes that acted, or all of them when
# it sent fewer (the program sends ~20 per period), the jobs follow the 200 ms grid (each job's records
# lie inside one period, and there are no more jobs than periods).
# Usage: cli_thread_budget.sh CONTEGO SCRIPTS_DIR
set -euo pipefail
contego="$1" scripts="$2"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
cat >"$dir/budget.policy" <<'POLICY'
device servos : pca9685 at i2c-1 0x40 { safe mode2(outdrv=1) }
task worker {
  exe "/usr/bin/python3"
  period 200ms; deadline 200ms; wcet 20ms; priority 1
  actuations 3
}
allow worker -> servos
limit worker -> servos 3 per job else ignore
POLICY
"$contego" run --policy "$dir/budget.policy" --task worker --audit "$dir/audit.jsonl" \
  --budget-factor 0 -- /usr/bin/python3 "$scripts/sleeping_thread_burst.py" 2.0 >"$dir/out"
grep -q "^sent" "$dir/out" || { echo "the program did not finish"; exit 1; }
python3 - "$dir/audit.jsonl" <<'PY'
import collections
import json
import sys

period_us = 200_000
acted = collections.Counter()
times = collections.defaultdict(list)
for line in open(sys.argv[1]):
    r = json.loads(line)
    if r.get("kind") != "decision" or r.get("addr") != 0x40:
        continue
    times[r["job"]].append(r["t_us"])
    if r["decision"] != "ignore":
        acted[r["job"]] += 1
jobs = sorted(times)
if len(jobs) < 8:
    sys.exit(f"only {len(jobs)} jobs seen")
span = max(max(t) for t in times.values()) - min(min(t) for t in times.values())
if len(jobs) > span // period_us + 2:
    sys.exit(f"{len(jobs)} jobs in {span} us: more than one per period")
for j in jobs:
    if max(times[j]) - min(times[j]) >= period_us:
        sys.exit(f"job {j} spans more than a period")
# Every job: min(sent, 3) writes acted (a loaded machine may starve the
# program for part of a period; it usually sends about 20 per job).
for j in jobs:
    if acted[j] != min(len(times[j]), 3):
        sys.exit(f"job {j}: {acted[j]} of {len(times[j])} writes acted, the budget is 3 per job")
if sum(1 for j in jobs if len(times[j]) > 3) < len(jobs) // 2:
    sys.exit("the program sent more than its budget in too few jobs to tell")
print("ok", len(jobs), "jobs, 3 writes acted in each")
PY
