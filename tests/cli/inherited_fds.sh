#!/usr/bin/env bash
# `contego run` hands the program only descriptors 0-2 and those named by
# --pass-fd: one its launcher left open without O_CLOEXEC is closed at exec
# (a bus node among them would reach the bus unchecked; the test bed's
# scenario 40 shows that refusal on a real adapter). A --pass-fd that is not
# open is refused before the program runs.
# Usage: inherited_fds.sh CONTEGO POLICIES_DIR
set -euo pipefail
contego="$1" policies="$2"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
run=("$contego" run --policy "$policies/rover.policy" --virtual-bus 1 --audit "$dir/a.jsonl" --task follower)

exec 7>"$dir/seven"  # no O_CLOEXEC: a launcher's leftover
if "${run[@]}" -- /bin/sh -c 'echo leaked >&7' 2>"$dir/e1"; then fail "the program wrote to an inherited descriptor"; fi
[ ! -s "$dir/seven" ] || fail "descriptor 7 reached the program"
"${run[@]}" --pass-fd 7 -- /bin/sh -c 'echo passed >&7' 2>"$dir/e2" || { cat "$dir/e2"; fail "--pass-fd 7"; }
grep -q passed "$dir/seven" || fail "--pass-fd 7 did not reach the program"
exec 7>&-
if "${run[@]}" --pass-fd 7 -- /bin/true 2>"$dir/e3"; then fail "a closed --pass-fd was accepted"; fi
grep -q "pass-fd 7: not an open descriptor" "$dir/e3" || { cat "$dir/e3"; fail "no reason for the closed descriptor"; }
echo "ok"
