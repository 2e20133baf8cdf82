#!/usr/bin/env bash
# Issue 11 through the command line: `contego monitor` with task bindings
# (gripper: user nobody; arm_init: user root), `contego run --socket --user`:
#  - a supervised gripper opening its own connection as arm_init is refused
#    and audited (hello-refused), the monitor keeps serving;
#  - a supervisor vouching for a program of the wrong user is refused before
#    the program runs (exit 2, the program never starts);
#  - `contego run --user nobody` runs the program as uid 65534; an unknown
#    user is refused with a message.
# Needs root (the program runs as nobody); skipped otherwise.
set -uo pipefail
contego="$1" policies="$2" attack="$3"
if [[ $(id -u) -ne 0 ]]; then printf "skipped: needs root\nok\n"; exit 0; fi
# shellcheck source=tests/intercept/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/cli_common.sh"
FAIL_SHOW=("*.err" "*.out" "*.jsonl")
chmod 0755 "$dir"
# The program runs as nobody, who may not reach into the build tree (a fresh
# clone under a private directory): run it from a copy in $dir.
cp "$attack" "$dir/attack_identity" && chmod 0755 "$dir/attack_identity"
attack="$dir/attack_identity"

sed -e '/^task arm_init {/a\  user "root"' -e '/^task gripper {/a\  user "nobody"' \
  "$policies/arm.policy" >"$dir/arm.policy"
"$contego" check "$dir/arm.policy" >"$dir/check.out" 2>&1 || fail "the bound policy does not compile"
grep -q "may run it: user nobody" "$dir/check.out" || fail "contego check does not show the binding"

sock="$dir/monitor.sock"
"$contego" monitor --policy "$dir/arm.policy" --virtual-bus 1 --socket "$sock" \
  --client-uid 65534 --audit "$dir/monitor.jsonl" >"$dir/monitor.out" 2>"$dir/monitor.err" &
monitor_pid=$!
wait_for_socket "$sock" || fail "the monitor did not start"
chmod 0666 "$sock"  # so that the supervised program can try

"$contego" run --socket "$sock" --task gripper --user nobody \
  -- "$attack" hello "$sock" arm_init >"$dir/impersonate.out" 2>"$dir/impersonate.err"
code=$?
[[ $code -eq 0 ]] || fail "the supervised gripper's own hello as arm_init: exit $code"
grep -aq '"kind":"hello-refused"' "$dir/monitor.jsonl" || fail "no hello-refused event"
echo "impersonation refused: ok"

"$contego" run --socket "$sock" --task arm_init --user nobody -- touch "$dir/ran" \
  >"$dir/wrong.out" 2>"$dir/wrong.err"
code=$?
[[ $code -eq 2 ]] || fail "a program of the wrong user for arm_init: exit $code"
grep -q "bound to uid 0" "$dir/wrong.err" || fail "no reason given: $(cat "$dir/wrong.err")"
[[ ! -e "$dir/ran" ]] || fail "the refused program ran"
echo "wrong user refused before the program runs: ok"

out=$("$contego" run --socket "$sock" --task gripper --user nobody -- id -u 2>"$dir/id.err")
[[ "$out" == 65534 ]] || fail "--user nobody ran the program as uid '$out'"
kill -0 "$monitor_pid" || fail "the monitor stopped"
echo "--user: ok"

"$contego" run --policy "$dir/arm.policy" --virtual-bus 1 --task gripper \
  --user no-such-user-contego -- true >"$dir/nouser.out" 2>"$dir/nouser.err"
code=$?
[[ $code -eq 2 ]] && grep -q "no user 'no-such-user-contego'" "$dir/nouser.err" ||
  fail "an unknown --user: exit $code, $(cat "$dir/nouser.err")"
echo "unknown user refused: ok"
stop_monitor || fail "the monitor exited $? on SIGTERM"
echo ok
