#!/usr/bin/env bash
# The learn loop of docs/learn.md on the vendors' call patterns, on a virtual
# bus, step by step as the README gives it:
#  1. observe: the free-running follower (contego run --complain), the 6DOF
#     Hand in three runs under one monitor (contego monitor --complain) and
#     a gripper on Adafruit's current driver generation (one 5-byte
#     auto-increment write per pulse, MODE1 read through I2C_RDWR);
#  2. contego policy generate, check --strict, contego test with the
#     generated tests;
#  3. enforce: the same programs under the generated policies, 0 dropped;
#  4. the paper's attacks against the generated policies: each dropped;
#  5. replay: the attack-free log against the shipped, the generated and a
#     tightened policy (--fail-on-change fails only on the last);
#  6. bad input: a damaged log and a file that is no audit log are refused
#     with the line.
# Usage: learn_loop.sh CONTEGO POLICIES_DIR VENDOR_DIR [SECONDS]
set -uo pipefail
contego="$1" policies="$2" vendor="$3" seconds="${4:-3}"
# shellcheck source=../intercept/cli_common.sh
source "$(dirname "$0")/../intercept/cli_common.sh"
FAIL_SHOW=("*.out" "*.err")
py=/usr/bin/python3

verdicts() {  # NAME LOG ARGS...: the counts, or fail with the unexpected decisions
  local name="$1" log="$2"
  shift 2
  "$py" "$vendor/verdicts.py" "$log" "$@" >"$dir/$name.verdicts" ||
    fail "$name: $(cat "$dir/$name.verdicts")"
  echo "$name: $(head -n1 "$dir/$name.verdicts")"
}

start_monitor() {  # POLICY NAME ARGS...
  local policy="$1" name="$2"
  shift 2
  "$contego" monitor --policy "$policy" --virtual-bus 1 --socket "$dir/$name.sock" \
    --audit "$dir/$name.jsonl" "$@" >"$dir/$name-monitor.out" 2>"$dir/$name-monitor.err" &
  monitor_pid=$!
  wait_for_socket "$dir/$name.sock" || fail "$name: the monitor did not start"
}

hand_runs() {  # NAME: the Hand's three runs through the monitor at $dir/NAME.sock
  local k=0 moves
  for moves in "open" "open close" "close open close"; do
    k=$((k + 1))
    # shellcheck disable=SC2086
    "$contego" run --socket "$dir/$1.sock" --task gripper -- "$py" "$vendor/sixdof_hand.py" \
      $moves >"$dir/$1-$k.out" 2>"$dir/$1-$k.err" || fail "$1 run $k: exit $?"
    grep -q "^done" "$dir/$1-$k.out" || fail "$1 run $k did not finish"
    sleep 1.1  # the next run in the next period of the gripper's grid
  done
}

# --- 1. observe ---------------------------------------------------------------
"$contego" run --policy "$policies/observe/rover.policy" --task follower --virtual-bus 1 \
  --complain --audit "$dir/rover-observe.jsonl" -- "$py" "$vendor/di_line_follow.py" \
  "$seconds" >"$dir/rover-observe.out" 2>"$dir/rover-observe.err" ||
  fail "rover observe: exit $?"
grep -q "COMPLAIN MODE" "$dir/rover-observe.err" || fail "complain mode was not announced"
grep -q '"kind":"start"' "$dir/rover-observe.jsonl" &&
  grep '"kind":"start"' "$dir/rover-observe.jsonl" | grep -q "mode complain" ||
  fail "the start record does not say complain mode"
"$contego" audit "$dir/rover-observe.jsonl" >"$dir/rover-observe-audit.out" ||
  fail "the observe log does not verify"
start_monitor "$policies/observe/arm.policy" arm-observe --complain
hand_runs arm-observe
stop_monitor || fail "the observing monitor exited $? on SIGTERM"
"$contego" run --policy "$policies/observe/arm.policy" --task gripper --virtual-bus 1 \
  --complain --audit "$dir/cpy-observe.jsonl" -- "$py" "$vendor/circuitpython_pca9685.py" \
  420 577 420 >"$dir/cpy-observe.out" 2>"$dir/cpy-observe.err" || fail "cpy observe: exit $?"
"$contego" audit "$dir/arm-observe.jsonl" >"$dir/arm-observe-audit.out" ||
  fail "the arm's observe log does not verify"
echo "observed: $(grep -c '"kind":"decision"' "$dir/rover-observe.jsonl") rover and" \
  "$(grep -c '"kind":"decision"' "$dir/arm-observe.jsonl") arm decisions"

# --- 2. generate, check, test --------------------------------------------------
for robot in rover arm cpy; do
  observed="$policies/observe/$robot.policy"
  [[ $robot == cpy ]] && observed="$policies/observe/arm.policy"
  "$contego" policy generate "$dir/$robot-observe.jsonl" --from "$observed" \
    -o "$dir/$robot-gen.policy" --tests "$dir/$robot-gen.test" >"$dir/$robot-gen.out" \
    2>"$dir/$robot-gen.err" || fail "$robot: generate exited $?"
  "$contego" check --strict "$dir/$robot-gen.policy" >"$dir/$robot-check.out" \
    2>"$dir/$robot-check.err" || fail "$robot: the generated policy fails check --strict"
  "$contego" test "$dir/$robot-gen.policy" "$dir/$robot-gen.test" >"$dir/$robot-test.out" \
    2>&1 || fail "$robot: the generated tests fail"
  grep -q "^# .*acted" "$dir/$robot-gen.policy" || fail "$robot: no rule says where it came from"
  echo "$robot: $(tail -n1 "$dir/$robot-test.out")"
done
grep -q "^task follower" "$dir/rover-gen.policy" && grep -q "period measured from the trace" \
  "$dir/rover-gen.policy" || fail "rover: the follower's period was not measured"

# --- 3. enforce: the same programs, nothing dropped --------------------------------
"$contego" run --policy "$dir/rover-gen.policy" --task follower --virtual-bus 1 \
  --audit "$dir/rover-enforce.jsonl" -- "$py" "$vendor/di_line_follow.py" "$seconds" \
  >"$dir/rover-enforce.out" 2>"$dir/rover-enforce.err" || fail "rover enforce: exit $?"
verdicts rover-enforce "$dir/rover-enforce.jsonl"
start_monitor "$dir/arm-gen.policy" arm-enforce
hand_runs arm-enforce
stop_monitor || fail "the enforcing monitor exited $? on SIGTERM"
verdicts arm-enforce "$dir/arm-enforce.jsonl"
"$contego" run --policy "$dir/cpy-gen.policy" --task gripper --virtual-bus 1 \
  --audit "$dir/cpy-enforce.jsonl" -- "$py" "$vendor/circuitpython_pca9685.py" 420 577 420 \
  >"$dir/cpy-enforce.out" 2>"$dir/cpy-enforce.err" || fail "cpy enforce: exit $?"
verdicts cpy-enforce "$dir/cpy-enforce.jsonl"
grep -c '"command_name":"led"' "$dir/cpy-enforce.jsonl" | grep -qx 3 ||
  fail "cpy enforce: the three pulses were not each decided as one led command"

# --- 4. the paper's attacks against the generated policies --------------------------
attack() {  # NAME POLICY TASK COMMAND WRITES...: COMMAND dropped, nothing else
  local name="$1" policy="$2" task="$3" command="$4"
  shift 4
  "$contego" run --policy "$policy" --task "$task" --virtual-bus 1 --audit "$dir/$name.jsonl" \
    -- "$py" "$vendor/attack_writes.py" "$@" >"$dir/$name.out" 2>"$dir/$name.err" ||
    fail "$name: exit $?"
  verdicts "$name" "$dir/$name.jsonl" --require-dropped "$command"
}
attack spoofed-speed "$dir/rover-gen.policy" follower set_left_speed 0x08:01,46,c8,00,00
attack wrong-direction "$dir/rover-gen.policy" follower bwd 0x08:01,6b,00,00,00
attack speed-burst "$dir/rover-gen.policy" follower set_left_speed 12*0x08:01,46,7d,00,00
attack dos-burst "$dir/rover-gen.policy" follower increase_speed 12*0x08:01,74,00,00,00
attack high-pulse "$dir/arm-gen.policy" gripper led \
  0x40:1a,00 0x40:1b,00 0x40:1c,bc 0x40:1d,02
attack prescale "$dir/arm-gen.policy" gripper prescale 0x40:00,11 0x40:fe,32
# Auto-increment on (as the driver leaves it), then a pulse past the window in one write.
attack cpy-high-pulse "$dir/cpy-gen.policy" gripper led 0x40:00,a0 0x40:1a,00,00,bc,02

# --- 5. replay ---------------------------------------------------------------------
"$contego" replay "$dir/rover-enforce.jsonl" --policy "$dir/rover-gen.policy" \
  --fail-on-change >"$dir/replay-same.out" 2>&1 || fail "replay against its own policy changed"
grep -q ": 0 would change" "$dir/replay-same.out" || fail "replay: $(head -n1 "$dir/replay-same.out")"
"$contego" replay "$dir/rover-enforce.jsonl" --policy "$policies/rover.policy" \
  >"$dir/replay-shipped.out" 2>&1 || fail "replay against the shipped policy: exit $?"
echo "replay, shipped rover.policy: $(head -n1 "$dir/replay-shipped.out")"
sed -E 's/speed in ([0-9]+)\.\.[0-9]+/speed in \1..\1/' "$dir/rover-gen.policy" \
  >"$dir/rover-tight.policy"
"$contego" replay "$dir/rover-enforce.jsonl" --policy "$dir/rover-tight.policy" \
  --fail-on-change >"$dir/replay-tight.out" 2>&1
code=$?
cat "$dir/replay-tight.out"
[[ $code -eq 1 ]] || fail "replay --fail-on-change on a tightened policy exited $code, not 1"
grep -q "RANGE_gopigo_set_left_speed" "$dir/replay-tight.out" ||
  fail "the replay table does not name the rule that changed"

# --- 6. bad input --------------------------------------------------------------------
sed '5s/"job":[0-9]*/"job":99/' "$dir/rover-enforce.jsonl" >"$dir/damaged.jsonl"
"$contego" replay "$dir/damaged.jsonl" --policy "$dir/rover-gen.policy" >"$dir/damaged.out" 2>&1
code=$?
[[ $code -eq 2 ]] && grep -q "line 6" "$dir/damaged.out" ||
  fail "a damaged log was not refused with its line (exit $code): $(cat "$dir/damaged.out")"
"$contego" replay "$policies/rover.policy" --policy "$dir/rover-gen.policy" \
  >"$dir/foreign.out" 2>&1
code=$?
[[ $code -eq 2 ]] && grep -q "line 1" "$dir/foreign.out" ||
  fail "a file that is no audit log was not refused (exit $code): $(cat "$dir/foreign.out")"
"$contego" replay "$dir/arm-enforce.jsonl" --policy "$dir/rover-gen.policy" \
  >"$dir/other-robot.out" 2>&1 || fail "replay of another robot's log: exit $?"
grep -q "task \`gripper\` of the log is not in the policy" "$dir/other-robot.out" ||
  fail "another policy's log was not named as such: $(head -n3 "$dir/other-robot.out")"
echo "ok"
