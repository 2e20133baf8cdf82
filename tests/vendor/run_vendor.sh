#!/usr/bin/env bash
# Vendor-style programs (written by us to send what the vendors' drivers
# send) under the example policies with `contego run`'s embedded monitor on a
# virtual bus: in normal operation no call of theirs is refused and nothing
# is substituted. The gripper's configuration writes (the Adafruit
# constructor) are dropped by design (arm.policy): ignored, never refused.
# Also checks that `contego audit --explain` names task, device and command.
# Usage: run_vendor.sh CONTEGO POLICIES_DIR VENDOR_DIR
set -euo pipefail
contego="$1" policies="$2" vendor="$3"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
count() { grep -c "\"decision\":\"$2\"" "$1" || true; }
run() {  # NAME POLICY TASK SCRIPT ARGS...
  local name="$1" policy="$2" task="$3"
  shift 3
  if ! "$contego" run --policy "$policies/$policy" --task "$task" --virtual-bus 1 \
      --audit "$dir/$name.jsonl" -- /usr/bin/python3 "$@" >"$dir/$name.out" 2>"$dir/$name.err"; then
    echo "$name: the program failed"; cat "$dir/$name.out" "$dir/$name.err"; exit 1
  fi
  grep -q "^done" "$dir/$name.out" || { echo "$name: did not finish"; cat "$dir/$name.err"; exit 1; }
  local rejects failsafes
  rejects="$(count "$dir/$name.jsonl" reject)" failsafes="$(count "$dir/$name.jsonl" failsafe)"
  echo "$name: $(count "$dir/$name.jsonl" allow) allowed, $(count "$dir/$name.jsonl" ignore)" \
       "ignored, $rejects refused, $failsafes substituted"
  if [ "$rejects" != 0 ] || [ "$failsafes" != 0 ]; then
    "$contego" audit --explain "$dir/$name.jsonl" | grep -v " allowed" || true
    exit 1
  fi
}
run rover rover.policy follower "$vendor/gopigo_follower.py" 4
if [ "$(count "$dir/rover.jsonl" ignore)" != 0 ]; then
  echo "rover: commands ignored"; "$contego" audit --explain "$dir/rover.jsonl" | grep IGNORED
  exit 1
fi
run gripper arm.policy gripper "$vendor/pca9685_gripper.py"
"$contego" audit --explain "$dir/rover.jsonl" >"$dir/explain.txt"
grep -q "follower (job [0-9]*) -> gopigo at i2c-1 0x08: set_left_speed(.*) allowed" \
  "$dir/explain.txt" || { echo "explain: no named decision"; head "$dir/explain.txt"; exit 1; }
grep -q "follower (job [0-9]*) -> line at i2c-1 0x06: board_name() allowed" "$dir/explain.txt" ||
  { echo "explain: the line sensor's board probe is not named"; exit 1; }
echo "ok"
