# The learn loop of docs/learn.md on the real kernel (i2c-stub's PCA9685 at
# 0x40): the 6DOF Hand observed in complain mode through `contego run`
# (program as uid 1000), a policy generated from the log, checked and tested,
# the Hand enforced by it with nothing dropped, two attacks dropped (read
# back from the chip outside contego), and the log replayed.
. /vm/lib.sh
A=0x40 PRESCALE=0xfe LED5_OFF=0x1c
OBSERVE=$POLICIES/observe/arm.policy
stub_set $A $PRESCALE 0x1e

hand() {  # LABEL POLICY AUDIT ARGS... -- MOVES: the Hand under contego run
  label=$1 policy=$2 audit=$3; shift 3
  run_logged "$label" contego run --policy "$policy" $BUS_ARGS --user 1000 --task gripper \
    --audit "$audit" "$@"
}

# --- observe: two runs in complain mode ---------------------------------------
hand observe1 "$OBSERVE" "$LOGDIR/observe.jsonl" --complain -- python3 $CLIENTS/sixdof_hand.py open
grep -q "COMPLAIN MODE" "$OUT" && ok "complain mode is announced on standard error" ||
  bad "no complain-mode banner"
usleep 1100000  # the next run in the gripper's next period
hand observe2 "$OBSERVE" "$LOGDIR/observe.jsonl" --complain -- python3 $CLIENTS/sixdof_hand.py open close
grep -q "^done" "$OUT" && ok "the Hand ran under the observe policy (exit $RC)" ||
  bad "the Hand did not finish under the observe policy"
run_logged audit contego audit "$LOGDIR/observe.jsonl"
[ $RC = 0 ] && grep -q "mode complain" "$LOGDIR/observe.jsonl" &&
  ok "the observe log verifies and its start record says complain mode" ||
  bad "the observe log does not verify or does not say complain mode"

# --- generate, check, test -------------------------------------------------------
GEN=$LOGDIR/arm-gen.policy
run_logged generate contego policy generate "$LOGDIR/observe.jsonl" --from "$OBSERVE" \
  -o "$GEN" --tests "$LOGDIR/arm-gen.test"
[ $RC = 0 ] && ok "contego policy generate wrote a policy" || bad "generate exited $RC"
show "$GEN"
run_logged check contego check --strict "$GEN"
[ $RC = 0 ] && ok "the generated policy passes check --strict" || bad "check --strict exited $RC"
run_logged test contego test "$GEN" "$LOGDIR/arm-gen.test"
[ $RC = 0 ] && ok "the generated tests pass" || bad "the generated tests exit $RC"

# --- enforce: nothing of the Hand dropped ----------------------------------------
hand enforce "$GEN" "$LOGDIR/enforce.jsonl" -- python3 $CLIENTS/sixdof_hand.py open close
dropped=$(grep '"kind":"decision"' "$LOGDIR/enforce.jsonl" | grep -vc '"decision":"allow"')
[ "$dropped" = 0 ] && grep -q "^done" "$OUT" &&
  ok "the Hand under the generated policy: every decision allowed" ||
  bad "the Hand under the generated policy: $dropped decision(s) not allowed"
expect_reg $A $PRESCALE 101 "the Hand's PRE_SCALE 101 reached the chip"

# --- attacks: the chip never sees them ----------------------------------------------
run_logged prescale contego run --policy "$GEN" $BUS_ARGS --user 1000 --task gripper \
  --audit "$LOGDIR/attack.jsonl" -- i2cset -y 1 $A $PRESCALE 0x03
expect_reg $A $PRESCALE 101 "PRE_SCALE tampering (0x03) from the gripper does not land"
run_logged pulse contego run --policy "$GEN" $BUS_ARGS --user 1000 --task gripper \
  --audit "$LOGDIR/attack.jsonl" -- python3 $CLIENTS/attack_writes.py \
  0x40:1a,00 0x40:1b,00 0x40:1c,bc 0x40:1d,02
grep -q '"decision":"ignore".*"rule_name":"RANGE_arm_led"' "$LOGDIR/attack.jsonl" &&
  ok "a high gripper pulse (700) is dropped by the generated range" ||
  bad "the high pulse was not dropped by RANGE_arm_led"
expect_word $A $LED5_OFF 420 "LED5 holds the safe state, never the high pulse"

# --- replay --------------------------------------------------------------------------
run_logged replay contego replay "$LOGDIR/enforce.jsonl" --policy "$GEN" --fail-on-change
[ $RC = 0 ] && grep -q ": 0 would change" "$OUT" &&
  ok "the enforce log replays against its policy with no change" || bad "replay exited $RC"
finish
