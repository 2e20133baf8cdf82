#!/usr/bin/env bash
# `contego run` with the embedded monitor: a rover loop that never sleeps
# (120 frames, 3 act per job, the rest are ignored) is held to its budget of
# dropped transfers (an over-budget event in the audit log), and not with
# --budget-factor 0. Factor 2 (16 dropped per 100 ms job), so that a slow
# machine (sanitizers, a loaded CI) still sends more than the budget.
# Usage: cli_budget.sh CONTEGO POLICIES_DIR SCRIPTS_DIR
set -euo pipefail
contego="$1" policies="$2" scripts="$3"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
run() {
  "$contego" run --policy "$policies/rover.policy" --task follower --audit "$dir/$1.jsonl" \
    "${@:2}" -- /usr/bin/python3 "$scripts/rover_burst.py" 120 >"$dir/$1.out"
  grep -q "sent 120" "$dir/$1.out" || { echo "$1: the program did not finish its writes"; exit 1; }
}
run held --budget-factor 2
grep -q '"kind":"over-budget"' "$dir/held.jsonl" ||
  { echo "--budget-factor 2: no over-budget event"; exit 1; }
run off --budget-factor 0
if grep -q '"kind":"over-budget"' "$dir/off.jsonl"; then
  echo "--budget-factor 0: held anyway"
  exit 1
fi
echo "ok"
