#!/usr/bin/env bash
# Signed checkpoints (issue 36): contego-monitor --checkpoint-key writes a
# `checkpoint` record every --checkpoint-interval and at stop, signed with a
# minisign key made by the minisign tool (`minisign -G -W`); `contego audit
# --keys-dir` verifies each one, and the minisign tool verifies the same
# signature; a changed checkpoint, an unknown key and an encrypted key are
# refused, each with its reason. Skipped (77) without the minisign tool.
# Usage: checkpoint.sh CONTEGO POLICIES_DIR
set -uo pipefail
contego="$1" policies="$2"
# shellcheck source=tests/intercept/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/../intercept/cli_common.sh"
FAIL_SHOW=("*.err" "*.out")
command -v minisign >/dev/null || { echo "skipped: no minisign tool (tools/bootstrap.sh installs it)"; exit 77; }
mkdir -p "$dir/keys" "$dir/other"
minisign -G -W -p "$dir/keys/robot.pub" -s "$dir/robot.key" >/dev/null 2>&1 || fail "minisign -G -W"
minisign -G -W -p "$dir/other/other.pub" -s "$dir/other.key" >/dev/null 2>&1 || fail "minisign -G -W"

"$contego" monitor --policy "$policies/rover.policy" --virtual-bus 1 --socket "$dir/m.sock" \
  --audit "$dir/audit.jsonl" --checkpoint-key "$dir/robot.key" --checkpoint-interval 1 \
  >"$dir/mon.out" 2>"$dir/mon.err" &
monitor_pid=$!
wait_for_socket "$dir/m.sock" || fail "the monitor did not start"
"$contego" run --socket "$dir/m.sock" --task follower -- i2cset -y 1 0x08 0x01 0x46 i \
  >/dev/null 2>&1 || true
for _ in $(seq 50); do
  [[ $(grep -c '"kind":"checkpoint"' "$dir/audit.jsonl") -ge 2 ]] && break
  sleep 0.1
done
kill -TERM "$monitor_pid" && wait "$monitor_pid" || fail "the monitor did not stop cleanly"
monitor_pid=""
n=$(grep -c '"kind":"checkpoint"' "$dir/audit.jsonl")
[[ $n -ge 2 ]] || fail "$n checkpoint records"
tail -n 1 "$dir/audit.jsonl" | grep -q '"kind":"checkpoint"' || fail "the last record is not the stop's checkpoint"

"$contego" audit "$dir/audit.jsonl" --keys-dir "$dir/keys" >"$dir/verify.out" 2>"$dir/verify.err" ||
  fail "contego audit --keys-dir refused the monitor's checkpoints"
grep -q "^  $n signed checkpoint(s) verified" "$dir/verify.out" || fail "not every checkpoint verified"
echo "contego audit --keys-dir: $n checkpoints verified: ok"

# The minisign tool verifies the same signature: the detail's first line is
# what was signed, the rest the signature file.
python3 - "$dir/audit.jsonl" "$dir/signed.txt" "$dir/signed.txt.minisig" <<'PY' || fail "extracting a checkpoint"
import json, sys
last = [json.loads(l) for l in open(sys.argv[1], "rb").read().split(b"\n") if l.startswith(b"{")][-1]
text, signature = last["detail"].split("\n", 1)
open(sys.argv[2], "w").write(text)
open(sys.argv[3], "w").write(signature)
PY
minisign -V -p "$dir/keys/robot.pub" -m "$dir/signed.txt" >"$dir/minisign.out" 2>&1 ||
  fail "the minisign tool does not verify the checkpoint"
echo "minisign -V verifies a checkpoint: ok"

if "$contego" audit "$dir/audit.jsonl" --keys-dir "$dir/other" >"$dir/other.out" 2>"$dir/other.err"; then
  fail "a checkpoint verified with another key"
fi
grep -q "not by any trusted key" "$dir/other.err" || fail "no reason for the unknown key"
# A checkpoint rewritten to anchor another hash, its chain repaired.
python3 - "$dir/audit.jsonl" "$dir/forged.jsonl" <<'PY' || fail "forging"
import hashlib, json, sys
lines = [l for l in open(sys.argv[1], "rb").read().split(b"\n") if l.startswith(b"{")]
out, prev = [], None
for raw in lines:
    r = json.loads(raw)
    if r.get("kind") == "checkpoint":
        r["detail"] = r["detail"].replace(" records,", "0 records,", 1)
    if prev is not None:
        r["prev"] = prev
    line = json.dumps(r, separators=(",", ":")).encode() if prev is not None or r.get("kind") == "checkpoint" else raw
    out.append(line)
    prev = hashlib.sha256(line).hexdigest()
open(sys.argv[2], "wb").write(b"\n".join(out) + b"\n")
PY
if "$contego" audit "$dir/forged.jsonl" --keys-dir "$dir/keys" >"$dir/forged.out" 2>"$dir/forged.err"; then
  fail "a changed checkpoint verified"
fi
grep -q "checkpoint NOT VERIFIED\|chain BROKEN" "$dir/forged.out" || fail "no reason for the changed checkpoint"
echo "changed checkpoint and unknown key refused: ok"

# An encrypted key (minisign -G without -W) refuses the start, saying why.
printf 'pw\npw\n' | minisign -G -p "$dir/enc.pub" -s "$dir/enc.key" >/dev/null 2>&1 || fail "minisign -G"
"$contego" monitor --policy "$policies/rover.policy" --virtual-bus 1 --socket "$dir/e.sock" \
  --audit "$dir/e.jsonl" --checkpoint-key "$dir/enc.key" >"$dir/enc.out" 2>"$dir/enc.err"
code=$?
[[ $code -eq 2 ]] && grep -q "minisign -G -W" "$dir/enc.err" || fail "an encrypted key: exit $code"
[[ ! -e "$dir/e.sock" ]] || fail "a monitor with an encrypted key started"
echo "encrypted key refused: ok"
echo ok
