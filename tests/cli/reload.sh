#!/usr/bin/env bash
# `contego reload` (issue 36): the running monitor takes a new policy in
# place while a supervised program keeps running, as a user does it:
#  - a changed limit (the servo window) is in effect for the program's next
#    command, its gripper sequence keeps its position (the close it sends
#    after the reload is allowed: started afresh, it would have been
#    replaced by an open), no safe state is driven, the program is not
#    restarted, and the `reload` record names both images' SHA-256; status
#    names the new image;
#  - refused, the old policy staying in force and the refusal audited: a
#    policy that does not compile (the tool says so), a bundle whose image
#    the verifier refuses, a policy that moves a device, one that drops the
#    task of a live session, a request from another uid;
#  - under --require-signed: an unsigned bundle and one signed by an unknown
#    key are refused, a signed one is taken (skipped without minisign).
# Usage: reload.sh CONTEGO POLICIES_DIR
set -uo pipefail
contego="$1" policies="$2"
daemon="$(dirname "$contego")/contego-monitor"
# shellcheck source=tests/intercept/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../intercept/cli_common.sh"
FAIL_SHOW=("*.err" "*.out" "*.jsonl")
chmod 0755 "$dir"
prog=""
trap '[[ -n "$prog" ]] && kill "$prog" 2>/dev/null; cli_cleanup' EXIT

# Four in a job for the gripper (its program writes a servo register by
# register, then several servos in one job); the servo window as shipped.
sed -e 's/limit gripper -> arm.led 1 per job else ignore/limit gripper -> arm.led 4 per job else ignore/' \
  "$policies/arm.policy" >"$dir/a.policy"
sed -e 's/^const SERVO_MAX = 600/const SERVO_MAX = 580/' "$dir/a.policy" >"$dir/b.policy"
grep -q "SERVO_MAX = 580" "$dir/b.policy" && grep -q "arm.led 4 per job" "$dir/a.policy" ||
  fail "the test's policies were not derived"

"$contego" monitor --policy "$dir/a.policy" --virtual-bus 1 --socket "$dir/m.sock" \
  --audit "$dir/audit.jsonl" --client-uid 65534 >"$dir/mon.out" 2>"$dir/mon.err" &
monitor_pid=$!
wait_for_socket "$dir/m.sock" || fail "the monitor did not start"
old_hash=$("$contego" status --socket "$dir/m.sock" --json |
  python3 -c 'import json,sys,re; print(re.search("SHA-256 ([0-9a-f]{64})", json.load(sys.stdin)["policy"])[1])')

# The gripper's program: a servo's pulse is written register by register
# (ON_L, ON_H, OFF_L, OFF_H of LEDn at 0x06 + 4n, as a library without
# auto-increment does); the group acts on OFF_H.
cat >"$dir/gripper.sh" <<'EOF'
servo() { # CHANNEL OFF
  base=$((6 + 4 * $1))
  i2cset -y 1 0x40 $base 0 && i2cset -y 1 0x40 $((base + 1)) 0 &&
    i2cset -y 1 0x40 $((base + 2)) $(($2 & 255)) && i2cset -y 1 0x40 $((base + 3)) $(($2 >> 8))
}
servo 5 420 && servo 0 590 || exit 1
echo 1 >"$1/phase1"
read -r _ <"$1/go"  # a FIFO: the test opens it once the policy is reloaded
sleep 1.1  # the next job
servo 0 590 && servo 5 577 || exit 1
echo 1 >"$1/phase2"
exec sleep 60
EOF
"$contego" run --socket "$dir/m.sock" --task gripper -- /bin/sh "$dir/gripper.sh" "$dir" \
  >"$dir/prog.out" 2>"$dir/prog.err" &
prog=$!
mkfifo "$dir/go"
wait_for "$dir/phase1" || fail "the program did not reach phase 1"

# Refused reloads first: each leaves policy a in force.
refused_reload() {  # NAME EXIT NEEDLE ARGS...
  local name="$1" want="$2" needle="$3"
  shift 3
  "$@" >"$dir/$name.out" 2>"$dir/$name.err"
  local code=$?
  [[ $code -eq $want ]] || fail "$name: exit $code, expected $want"
  grep -qF -- "$needle" "$dir/$name.err" || fail "$name: no '$needle' in the message"
  echo "$name refused: ok"
}
printf 'task broken {\n' >"$dir/broken.policy"
refused_reload broken 2 "broken.policy" "$contego" reload --socket "$dir/m.sock" \
  --policy "$dir/broken.policy"
"$contego" check "$dir/b.policy" --emit-bundle "$dir/b.bundle" >/dev/null 2>&1 ||
  fail "contego check --emit-bundle"
python3 - "$dir/b.bundle" "$dir/bad.bundle" <<'PY' || fail "the corrupt bundle"
import json, sys
b = json.load(open(sys.argv[1]))
image = bytearray.fromhex(b["image"])
image[40] ^= 0xFF  # a byte under the checksum: the verifier refuses it
b["image"] = image.hex()
import hashlib
b["image_sha256"] = hashlib.sha256(image).hexdigest()
json.dump(b, open(sys.argv[2], "w"))
PY
refused_reload verifier 1 "refused" "$contego" reload --socket "$dir/m.sock" \
  --bundle "$dir/bad.bundle"
sed -e 's/at i2c-1 0x40/at i2c-1 0x41/' "$dir/a.policy" >"$dir/moved.policy"
refused_reload moved_device 1 "a reload keeps the devices" "$contego" reload \
  --socket "$dir/m.sock" --policy "$dir/moved.policy"
sed -e 's/gripper/grabber/g' "$dir/a.policy" >"$dir/renamed.policy"
refused_reload live_task 1 "task gripper has 1 live session(s)" "$contego" reload \
  --socket "$dir/m.sock" --policy "$dir/renamed.policy"
if [[ $(id -u) -eq 0 ]]; then
  chmod 0666 "$dir/m.sock"
  refused_reload other_uid 1 "only root or the monitor's uid" \
    setpriv --reuid 65534 --regid 65534 --clear-groups "$contego" reload --socket "$dir/m.sock" \
    --policy "$dir/b.policy"
fi
[[ $(grep -c '"kind":"reload-refused"' "$dir/audit.jsonl") -ge 3 ]] ||
  fail "the refused reloads are not audited"
grep -q '"kind":"reload"' "$dir/audit.jsonl" && fail "a refused reload took effect"

# The reload: the servo window shrinks to 580 while the gripper runs.
"$contego" reload --socket "$dir/m.sock" --policy "$dir/b.policy" >"$dir/reload.out" \
  2>"$dir/reload.err" || fail "contego reload exit $?"
grep -q "^contego reload: reloaded: policy .*b.policy by uid $(id -u): image SHA-256 $old_hash -> [0-9a-f]\{64\}" \
  "$dir/reload.out" || fail "the reload's answer"
new_hash=$(sed -n 's/.* -> \([0-9a-f]\{64\}\).*/\1/p' "$dir/reload.out" | head -1)
[[ "$new_hash" != "$old_hash" ]] || fail "the image did not change"
echo go >"$dir/go"
wait_for "$dir/phase2" || fail "the program did not reach phase 2"
kill -0 "$prog" 2>/dev/null || fail "the supervised program ended"
python3 - "$dir/audit.jsonl" "$old_hash" "$new_hash" <<'PY' || fail "the audit after the reload"
import json, sys
records = [json.loads(l) for l in open(sys.argv[1], "rb").read().split(b"\n") if l.startswith(b"{")]
at = next(i for i, r in enumerate(records) if r.get("kind") == "reload")
detail = records[at]["detail"]
assert sys.argv[2] in detail and sys.argv[3] in detail, detail
after = records[at + 1:]
assert not any(r.get("kind") in ("safe-state", "session-end") or "safe" in r.get("kind", "")
               for r in after), [r for r in after if "kind" in r]
acts = [r for r in after if r.get("command_name") == "led" and r.get("reason_name") != "staged"]
by_index = {(r["index"], r["fields"][1]): r["decision"] for r in acts}  # on, off, ...
assert by_index.get((0, 590)) == "ignore", by_index   # the new window (<= 580)
assert by_index.get((5, 577)) == "allow", by_index    # the sequence kept its position
PY
"$contego" status --socket "$dir/m.sock" >"$dir/status.out" || fail "status after the reload"
grep -q "b.policy (bundle reloaded by uid $(id -u), SHA-256 $new_hash)" "$dir/status.out" ||
  fail "status does not name the reloaded policy"
grep -q '^  gripper .*sessions 1' "$dir/status.out" || fail "the gripper's session is gone"
echo "reload with a live program: ok"
kill "$prog" && wait "$prog" 2>/dev/null
prog=""
kill -TERM "$monitor_pid" && wait "$monitor_pid" || fail "the monitor did not stop cleanly"
monitor_pid=""
"$contego" audit "$dir/audit.jsonl" >"$dir/verify.out" 2>&1 || fail "the chain does not verify"

if ! command -v minisign >/dev/null; then
  echo "skipped: the signed reloads need the minisign tool (tools/bootstrap.sh installs it)"
  echo ok
  exit 0
fi
mkdir -p "$dir/keys" "$dir/other"
minisign -G -W -p "$dir/keys/robot.pub" -s "$dir/robot.key" >/dev/null 2>&1 || fail "minisign -G"
minisign -G -W -p "$dir/other/other.pub" -s "$dir/other.key" >/dev/null 2>&1 || fail "minisign -G"
"$contego" check "$dir/a.policy" --emit-bundle "$dir/a.bundle" >/dev/null 2>&1 || fail "bundle a"
minisign -S -s "$dir/robot.key" -m "$dir/a.bundle" >/dev/null 2>&1 || fail "minisign -S a"
"$daemon" --bundle "$dir/a.bundle" --require-signed --keys-dir "$dir/keys" --virtual-bus 1 \
  --socket "$dir/s.sock" --audit "$dir/signed.jsonl" >"$dir/signed.out" 2>"$dir/signed.err" &
monitor_pid=$!
wait_for_socket "$dir/s.sock" || fail "the signed monitor did not start"
refused_reload unsigned 1 "has no signature" "$contego" reload --socket "$dir/s.sock" \
  --policy "$dir/b.policy"
minisign -S -s "$dir/other.key" -m "$dir/b.bundle" >/dev/null 2>&1 || fail "minisign -S other"
refused_reload unknown_key 1 "not by any trusted key" "$contego" reload --socket "$dir/s.sock" \
  --bundle "$dir/b.bundle"
minisign -S -s "$dir/robot.key" -m "$dir/b.bundle" -t "arm, release 8" >/dev/null 2>&1 ||
  fail "minisign -S b"
"$contego" reload --socket "$dir/s.sock" --bundle "$dir/b.bundle" >"$dir/signed_reload.out" \
  2>"$dir/signed_reload.err" || fail "a signed reload was refused"
# A key ID as minisign prints it: no leading zeros (1 key in 16 has one).
grep -q 'signed by key ID [0-9A-F]\{1,16\} ([^)]*robot.pub), trusted comment "arm, release 8"' \
  "$dir/signed_reload.out" || fail "the signed reload does not name its signer"
echo "signed reloads: ok"
echo ok
