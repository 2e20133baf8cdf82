#!/usr/bin/env bash
# SIGKILL to `contego run --policy` (embedded monitor, issue 11): the
# supervisor and its monitor die at once, so its guardian process drives the
# safe state with a monitor of its own (audited, the chain continued), the
# program dies with its supervisor (PR_SET_PDEATHSIG), and a process it left
# behind gets ENOSYS from the bus node: nothing reaches a bus.
# Usage: cli_supervisor_killed.sh CONTEGO POLICIES_DIR SCRIPTS_DIR
set -uo pipefail
contego="$1" policies="$2" scripts="$3"
# shellcheck source=tests/intercept/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/cli_common.sh"

"$contego" run --policy "$policies/rover.policy" --task follower --virtual-bus 1 \
  --audit "$dir/audit.jsonl" --virtual-state "$dir/state" \
  -- /usr/bin/python3 "$scripts/orphan_open.py" "$dir/pid" \
  >"$dir/out" 2>"$dir/err" &
run_pid=$!
wait_for "$dir/pid" || fail "the program did not start"
child=$(cat "$dir/pid")
grep -q "gopigo2 0x08" "$dir/state" 2>/dev/null && fail "virtual state written before the end"
kill -KILL "$run_pid"
wait "$run_pid" 2>/dev/null
gone "$child" || fail "the program (pid $child) outlived its supervisor"
wait_for "$dir/state" || fail "the guardian wrote no virtual state"
grep -q "gopigo2 0x08 motion=0x78" "$dir/state" || fail "the GoPiGo2 is not stopped"
grep -aF '"kind":"safe-state"' "$dir/audit.jsonl" | grep -qF "ended without a clean exit" ||
  fail "no safe-state event from the guardian"
grep -qF "its guardian drives the safe state" "$dir/err" || fail "no message from the guardian"
"$contego" audit "$dir/audit.jsonl" >"$dir/verify" 2>&1 || fail "the audit chain does not verify"
for _ in $(seq 100); do grep -q "^orphan:" "$dir/out" && break; sleep 0.1; done
grep -qx "orphan: ENOSYS" "$dir/out" || fail "the orphan did not get ENOSYS opening the bus"
echo "ok"
