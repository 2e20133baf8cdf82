#!/usr/bin/env bash
# `contego run` stopped by SIGTERM ends everything the program started, not
# only the processes its supervisor has seen: a grandchild asleep since
# before the stop (never a call the filter sends) and one that left into a
# session of its own are gone when `contego run` returns, within seconds.
# Usage: stop_tree.sh CONTEGO POLICIES_DIR
set -euo pipefail
contego="$1" policies="$2"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
"$contego" run --policy "$policies/rover.policy" --virtual-bus 1 --audit "$dir/a.jsonl" \
  --task follower -- /bin/sh -c "sleep 300 & echo \$! >$dir/sleeper; \
    setsid sleep 300 & echo \$! >$dir/escaper; wait" >"$dir/out" 2>&1 &
run=$!
for _ in $(seq 100); do [ -s "$dir/sleeper" ] && [ -s "$dir/escaper" ] && break; sleep 0.1; done
[ -s "$dir/escaper" ] || fail "the program did not start its children"
sleep 0.5
start=$SECONDS
kill -TERM "$run"
wait "$run" || true
(( SECONDS - start <= 10 )) || fail "contego run took $((SECONDS - start)) s to end"
# Gone, or a zombie its new parent has yet to reap: not running.
running() { [ -r "/proc/$1/stat" ] && ! grep -q '^[0-9]* (.*) Z' "/proc/$1/stat"; }
for who in sleeper escaper; do
  pid=$(cat "$dir/$who")
  for _ in $(seq 20); do running "$pid" || break; sleep 0.1; done
  if running "$pid"; then kill -KILL "$pid"; fail "the $who (pid $pid) outlived contego run"; fi
done
echo "ok"
