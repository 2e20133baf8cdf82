#!/usr/bin/env bash
# Policy bundles and their signatures (issues 36, 37), through the command
# line as a user runs them:
#  - `contego check --emit-bundle` writes one file with the image and the
#    task bindings; contego-monitor --bundle enforces both (a program of the
#    wrong user for a bound task is refused before it runs), where the image
#    alone had lost the binding;
#  - contego-monitor never compiles a policy: --policy alone is refused with
#    the way to do it; `contego monitor --policy` compiles, then runs it
#    (same PID, the start record names the policy and its image hash);
#  - minisign: a bundle signed with the real tool and a key in --keys-dir
#    starts and the start record names the signer; a changed bundle, an
#    unknown key, an unsigned bundle under --require-signed, an image or a
#    policy under --require-signed: each refused with its reason, nothing
#    started. Without the minisign tool those checks are skipped and said.
# Usage: signed_bundle.sh CONTEGO POLICIES_DIR
set -uo pipefail
contego="$1" policies="$2"
daemon="$(dirname "$contego")/contego-monitor"
# shellcheck source=tests/intercept/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../intercept/cli_common.sh"
FAIL_SHOW=("*.err" "*.jsonl")
chmod 0755 "$dir"

start_monitor() {  # NAME ARGS...: a monitor on $dir/NAME.sock, its pid in monitor_pid
  local name="$1"
  shift
  "$@" --virtual-bus 1 --socket "$dir/$name.sock" --audit "$dir/$name.jsonl" \
    --client-uid 65534 >"$dir/$name.out" 2>"$dir/$name.err" &
  monitor_pid=$!
}
stop_monitor() {
  kill -TERM "$monitor_pid" && wait "$monitor_pid"
  monitor_pid=""
}
refused() {  # NAME NEEDLE ARGS...: the daemon exits 2 naming NEEDLE, opens no socket
  local name="$1" needle="$2"
  shift 2
  "$@" --virtual-bus 1 --socket "$dir/$name.sock" --audit "$dir/$name.jsonl" \
    >"$dir/$name.out" 2>"$dir/$name.err"
  local code=$?
  [[ $code -eq 2 ]] || fail "$name: exit $code, expected 2"
  grep -qF -- "$needle" "$dir/$name.err" || fail "$name: no '$needle' in the message"
  [[ ! -e "$dir/$name.sock" ]] || fail "$name: a socket was opened"
  echo "$name refused: ok"
}

[[ -x "$daemon" ]] || fail "no contego-monitor beside $contego"
sed -e '/^task arm_init {/a\  user "root"' "$policies/arm.policy" >"$dir/arm.policy"
"$contego" check "$dir/arm.policy" --emit "$dir/arm.img" --emit-bundle "$dir/arm.bundle" \
  >"$dir/check.out" 2>"$dir/check.err" || fail "contego check --emit-bundle"
grep -q "wrote $dir/arm.bundle (.*minisign -Sm" "$dir/check.err" || fail "no bundle line"
grep -q '"user": "root"' "$dir/arm.bundle" || fail "the bundle does not carry the binding"

# The bundle enforces the binding: arm_init is root's, so a program of
# nobody is refused before it runs.
start_monitor bundle "$daemon" --bundle "$dir/arm.bundle"
wait_for_socket "$dir/bundle.sock" || fail "contego-monitor --bundle did not start"
grep -q "arm.bundle (bundle of $dir/arm.policy, SHA-256 [0-9a-f]\{64\}).*\"kind\":\"start\"" \
  "$dir/bundle.jsonl" || fail "the start record does not name the bundle"
chmod 0666 "$dir/bundle.sock"
if [[ $(id -u) -eq 0 ]]; then
  "$contego" run --socket "$dir/bundle.sock" --task arm_init --user nobody -- touch "$dir/ran" \
    >"$dir/wrong.out" 2>"$dir/wrong.err"
  code=$?
  [[ $code -eq 2 ]] && grep -q "bound to uid 0" "$dir/wrong.err" ||
    fail "the bundle's binding was not enforced: exit $code"
  [[ ! -e "$dir/ran" ]] || fail "the refused program ran"
  echo "binding from the bundle enforced: ok"
else
  echo "skipped: the binding check needs root (the program runs as nobody)"
fi
stop_monitor || fail "contego-monitor did not stop cleanly"

# The daemon never compiles; the tool does, then becomes the daemon.
refused daemon_policy "does not compile policies" "$daemon" --policy "$dir/arm.policy"
start_monitor tool "$contego" monitor --policy "$dir/arm.policy"
wait_for_socket "$dir/tool.sock" || fail "contego monitor --policy did not start"
[[ "$(readlink "/proc/$monitor_pid/exe")" == */contego-monitor ]] ||
  fail "the serving process is $(readlink "/proc/$monitor_pid/exe"), not contego-monitor"
grep -q "$dir/arm.policy (SHA-256 [0-9a-f]\{64\}).*\"kind\":\"start\"" "$dir/tool.jsonl" ||
  fail "the start record does not name the compiled policy"
stop_monitor || fail "contego monitor did not stop cleanly"
echo "contego monitor --policy runs contego-monitor (same pid): ok"

refused changed_image "is not the image policy" "$contego" monitor --policy "$dir/arm.policy" \
  --image "$dir/arm.bundle"
refused unsigned_required "has no signature" "$daemon" --bundle "$dir/arm.bundle" \
  --require-signed --keys-dir "$dir/keys"
refused policy_required "--require-signed enforces a signed --bundle" \
  "$contego" monitor --policy "$dir/arm.policy" --require-signed
refused image_required "--require-signed enforces a signed --bundle" \
  "$daemon" --image "$dir/arm.img" --image-sha256 0 --require-signed

if ! command -v minisign >/dev/null; then
  echo "skipped: the signature checks need the minisign tool (tools/bootstrap.sh installs it)"
  echo ok
  exit 0
fi
mkdir -p "$dir/keys" "$dir/other"
minisign -G -W -p "$dir/keys/robot.pub" -s "$dir/robot.key" >/dev/null 2>&1 || fail "minisign -G"
minisign -G -W -p "$dir/other/other.pub" -s "$dir/other.key" >/dev/null 2>&1 || fail "minisign -G"
minisign -S -s "$dir/robot.key" -m "$dir/arm.bundle" -t "arm policy, release 7" >/dev/null 2>&1 ||
  fail "minisign -S"
start_monitor signed "$daemon" --bundle "$dir/arm.bundle" --require-signed --keys-dir "$dir/keys"
wait_for_socket "$dir/signed.sock" || fail "a signed bundle did not start"
# A key ID as minisign prints it: no leading zeros (1 key in 16 has one).
grep -q 'signed by key ID [0-9A-F]\{1,16\} ([^)]*robot.pub), trusted comment \\"arm policy, release 7\\".*"kind":"start"' \
  "$dir/signed.jsonl" || fail "the start record does not name the signer"
stop_monitor || fail "the signed monitor did not stop cleanly"
echo "signed bundle: ok"

refused unknown_key "not by any trusted key" "$daemon" --bundle "$dir/arm.bundle" \
  --keys-dir "$dir/other"
cp "$dir/arm.bundle" "$dir/changed.bundle"
cp "$dir/arm.bundle.minisig" "$dir/changed.bundle.minisig"
sed -i 's/"user": "root"/"user": "nobody"/' "$dir/changed.bundle"
refused changed_bundle "does not match the signed data" "$daemon" --bundle "$dir/changed.bundle" \
  --keys-dir "$dir/keys"
echo ok
