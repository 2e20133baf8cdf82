#!/usr/bin/env bash
# `contego status` against a running monitor with a live supervised task:
# the policy with its image's SHA-256, the task's live session and its
# decisions, the devices, the audit log's path and last hash (as the log's
# own last line says); the same as JSON. Refused to a supervised program and
# to another uid (audited), each with its reason. The read-only status
# socket: the status group reads the status there, nothing else goes through.
# Usage: status.sh CONTEGO POLICIES_DIR
set -euo pipefail
contego="$1" policies="$2"
dir="$(mktemp -d)"
chmod 755 "$dir"
mon="" prog=""
cleanup() {
  [ -n "$prog" ] && kill "$prog" 2>/dev/null && wait "$prog" 2>/dev/null
  [ -n "$mon" ] && kill "$mon" 2>/dev/null && wait "$mon" 2>/dev/null
  rm -rf "$dir"
}
trap cleanup EXIT
fail() { echo "FAIL: $*"; cat "$dir/st.out" 2>/dev/null; exit 1; }
"$contego" monitor --policy "$policies/rover.policy" --virtual-bus 1 --socket "$dir/m.sock" \
  --audit "$dir/audit.jsonl" --client-uid "$(id -u)" --client-uid 65534 \
  --status-socket "$dir/s.sock" --status-group 4242 2>"$dir/mon.err" &
mon=$!
for _ in $(seq 100); do [ -S "$dir/m.sock" ] && break; sleep 0.1; done
[ -S "$dir/m.sock" ] || { cat "$dir/mon.err"; fail "the monitor did not start"; }
grep -q 'rover.policy (SHA-256 [0-9a-f]\{64\}).*"kind":"start"' "$dir/audit.jsonl" ||
  fail "the start record does not name the policy's image hash"

# A live task: two commands, then it waits.
"$contego" run --socket "$dir/m.sock" --task follower -- /bin/sh -c \
  "i2cset -y 1 0x08 0x01 0x46 i; i2cset -y 1 0x08 0x01 0x46 i; touch $dir/sent; exec sleep 30" \
  >"$dir/prog.out" 2>&1 &
prog=$!
for _ in $(seq 100); do [ -e "$dir/sent" ] && break; sleep 0.1; done
[ -e "$dir/sent" ] || { cat "$dir/prog.out"; fail "the program did not send"; }

"$contego" status --socket "$dir/m.sock" --json >"$dir/st.out" || fail "status --json exit $?"
python3 - "$dir/st.out" "$dir/audit.jsonl" <<'PY' || fail "the JSON status"
import json, sys
s = json.load(open(sys.argv[1]))
assert "rover.policy (SHA-256 " in s["policy"], s["policy"]
follower = next(t for t in s["tasks"] if t["name"] == "follower")
assert follower["sessions"] == 1, follower
assert sum(follower["decisions"].values()) >= 2, follower
assert follower["job"] >= 1, follower
assert any(d["name"] == "gopigo" and d["latched"] is False for d in s["devices"]), s["devices"]
assert s["audit"]["path"] == sys.argv[2], s["audit"]
import hashlib
# The chain's anchor: the SHA-256 of the last record's line (no newline; the
# file may end in preallocated zeros).
last = [l for l in open(sys.argv[2], "rb").read().split(b"\n") if l.startswith(b"{")][-1]
assert s["audit"]["last_hash"] == hashlib.sha256(last).hexdigest(), "last hash"
assert s["complain"] is False and s["uptime_s"] >= 0
line = next(d for d in s["devices"] if d["name"] == "line")
assert 0 <= line["sample_age_ms"] < 60000, line          # the sensor's newest reading
gopigo = next(d for d in s["devices"] if d["name"] == "gopigo")
assert gopigo["safe_state_age_s"] >= 0 and "sample_age_ms" not in gopigo, gopigo
assert len(s["image_sha256"]) == 64 and s["image_sha256"] in s["policy"], s["image_sha256"]
PY
"$contego" status --socket "$dir/m.sock" >"$dir/st.out" || fail "status exit $?"
grep -q '^  follower .*sessions 1' "$dir/st.out" || fail "the human status has no live follower"
grep -q '^  gopigo .* ok, safe state driven [0-9]* s ago' "$dir/st.out" || fail "the human status has no gopigo"
grep -q '^  line .* ok, newest reading [0-9]* ms old' "$dir/st.out" || fail "the human status has no reading age"

# A supervised program asks (the task's one session free again): refused,
# whatever its uid.
kill "$prog" && wait "$prog" 2>/dev/null || true
prog=""
sleep 0.5
if "$contego" run --socket "$dir/m.sock" --task follower -- "$contego" status --socket "$dir/m.sock" \
    >"$dir/st.out" 2>&1; then
  fail "a supervised program read the status"
fi
grep -q "supervised by contego" "$dir/st.out" || fail "no reason for the supervised program"
if [ "$(id -u)" = 0 ]; then
  chmod o+rw "$dir/m.sock"
  if setpriv --reuid 65534 --regid 65534 --clear-groups "$contego" status --socket "$dir/m.sock" \
      >"$dir/st.out" 2>&1; then
    fail "uid 65534 read the status"
  fi
  # A client uid (it may connect, to run tasks), not an operator.
  grep -q "only root, the monitor's uid or the status group" "$dir/st.out" ||
    fail "no reason for uid 65534"
  grep -q '"kind":"request-refused"\|request-refused' "$dir/audit.jsonl" || fail "the refusal is not audited"
  # The status group (4242): on the main socket for a client uid, on the
  # read-only status socket for anyone in it (primary or supplementary).
  setpriv --reuid 65534 --regid 65534 --groups 4242 "$contego" status --socket "$dir/m.sock" \
    >"$dir/st.out" 2>&1 || fail "a client uid in the status group was refused"
  chmod o+rw "$dir/s.sock"
  setpriv --reuid 4321 --regid 4321 --groups 4242 "$contego" status --socket "$dir/s.sock" --json \
    >"$dir/st.out" 2>&1 || fail "a member of the status group was refused on the status socket"
  grep -q '"image_sha256"' "$dir/st.out" || fail "no status on the status socket"
  setpriv --reuid 4321 --regid 4242 --clear-groups "$contego" status --socket "$dir/s.sock" \
    >"$dir/st.out" 2>&1 || fail "a peer whose primary group is the status group was refused"
  if setpriv --reuid 4321 --regid 4321 --clear-groups "$contego" status --socket "$dir/s.sock" \
      >"$dir/st.out" 2>&1; then
    fail "a peer outside the status group read the status"
  fi
  grep -q "the status group may read its status" "$dir/st.out" || fail "no reason for uid 4321"
  grep -q 'pid [0-9]* uid 4321: status: only root' "$dir/audit.jsonl" ||
    fail "the refused peer is not audited"
  # The status socket answers nothing else, even to root.
  if "$contego" reset gopigo --socket "$dir/s.sock" >"$dir/st.out" 2>&1; then
    fail "a reset went through the status socket"
  fi
  grep -q "status requests only" "$dir/st.out" || fail "no reason for the reset"
  if "$contego" run --socket "$dir/s.sock" --task follower -- true >"$dir/st.out" 2>&1; then
    fail "a task ran through the status socket"
  fi
  grep -q "status requests only" "$dir/st.out" || fail "no reason for the hello"
  grep -q 'message type [0-9]*: the status socket answers status requests only' "$dir/audit.jsonl" ||
    fail "the refused requests are not audited"
fi

# A degraded start (the GoPiGo and the line sensor where the virtual bus has
# nothing): the status says which safe state was never driven and which
# sensor has no reading, for as long as it lasts.
kill "$mon" && wait "$mon" 2>/dev/null || true
mon=""
sed -e 's/^device gopigo : gopigo2 at i2c-1 0x08/device gopigo : gopigo2 at i2c-1 0x09/' \
  -e 's/^device line : line_follower at i2c-1 0x06/device line : line_follower at i2c-1 0x07/' \
  "$policies/rover.policy" >"$dir/away.policy"
"$contego" monitor --policy "$dir/away.policy" --virtual-bus 1 --socket "$dir/d.sock" \
  --audit "$dir/d.jsonl" --allow-degraded 2>"$dir/mon.err" &
mon=$!
for _ in $(seq 100); do [ -S "$dir/d.sock" ] && break; sleep 0.1; done
[ -S "$dir/d.sock" ] || { cat "$dir/mon.err"; fail "the degraded monitor did not start"; }
"$contego" status --socket "$dir/d.sock" >"$dir/st.out" || fail "status exit $?"
grep -q '^  gopigo .* ok, SAFE STATE NOT DRIVEN since the start (--allow-degraded)' "$dir/st.out" ||
  fail "the status does not say the GoPiGo's safe state was never driven"
grep -q '^  line .* ok, NO READING (its signals are unavailable)' "$dir/st.out" ||
  fail "the status does not say the line sensor has no reading"
"$contego" status --socket "$dir/d.sock" --json >"$dir/st.out" || fail "status --json exit $?"
python3 -c '
import json, sys
s = {d["name"]: d for d in json.load(open(sys.argv[1]))["devices"]}
assert s["gopigo"]["safe_state_age_s"] is None and s["line"]["sample_age_ms"] is None, s
' "$dir/st.out" || fail "the JSON status of the degraded start"
echo "ok"
