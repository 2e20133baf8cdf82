# policies/arm.policy on the stub's PCA9685 (0x40), in mode $MODE (embedded:
# `contego run --policy`; monitor: `contego monitor` as its own user and
# `contego run --socket` as uid 1000). What reaches the chip is read back
# outside contego. Registers: PRE_SCALE 0xFE, LED5 = 0x1A..0x1D (ON_L, ON_H,
# OFF_L, OFF_H); the safe state is LED5 off=420.
. /vm/lib.sh
A=0x40 PRESCALE=0xfe LED5_OFF=0x1c

# The chip as it comes out of reset (MODE1 0x11: asleep, so PRE_SCALE takes
# writes; PRE_SCALE 30 = 200 Hz), gripper at 0.
stub_set $A 0x00 0x11
stub_set $A $PRESCALE 0x1e
stub_set $A $LED5_OFF 0
stub_set $A $((LED5_OFF + 1)) 0

if [ "$MODE" = monitor ]; then
  start_monitor arm.policy || finish
  expect_word $A $LED5_OFF 420 "safe state (gripper open, 420) on the adapter after the monitor's start"
fi

# --- configuration registers: only arm_init, only the vendor's 60 Hz value ---
run_logged prescale3 under $MODE arm.policy arm_init i2cset -y 1 $A $PRESCALE 0x03
expect_reg $A $PRESCALE 0x1e "arm_init's PRE_SCALE=0x03 is refused: PRE_SCALE keeps its value"
[ "$MODE" = embedded ] &&
  expect_word $A $LED5_OFF 420 "safe state (gripper open, 420) on the adapter after contego run"
run_logged prescale101 under $MODE arm.policy arm_init i2cset -y 1 $A $PRESCALE 101
[ $RC = 0 ] && ok "i2cset of PRE_SCALE=101 by arm_init exits 0" || bad "i2cset PRE_SCALE=101 exit $RC"
expect_reg $A $PRESCALE 101 "arm_init's PRE_SCALE=101 lands"
run_logged prescale_gripper under $MODE arm.policy gripper i2cset -y 1 $A $PRESCALE 0x03
# arm.policy drops the gripper's configuration writes and reports success (the
# vendor library's constructor writes PRE_SCALE and must not fail).
[ $RC = 0 ] && ok "gripper's PRE_SCALE write is dropped, i2cset told it succeeded" ||
  bad "gripper's PRE_SCALE write failed in i2cset (exit $RC)"
expect_reg $A $PRESCALE 101 "gripper's PRE_SCALE write does not land"

# --- the gripper sequence, a high pulse, then the task is killed --------------
d=$(sync_dir)
echo "  \$ gripper_seq.py --sync $d --hold 420 577 420 900 (under contego, background)"
under $MODE arm.policy gripper python3 $CLIENTS/gripper_seq.py --sync "$d" --hold \
  420 577 420 900 >"$LOGDIR/grip.out" 2>&1 &
grip_pid=$!
await "$d" start $grip_pid || { show "$LOGDIR/grip.out"; finish; }
expect_word $A $LED5_OFF 420 "safe state on the adapter while the supervised task starts"
stub_set $A $LED5_OFF 0  # so that the first pulse is seen to land
ack "$d" start
k=0
for want in 420 577 420; do
  await "$d" $k $grip_pid || break
  expect_word $A $LED5_OFF $want "gripper sequence step $k: pulse $want lands"
  ack "$d" $k
  k=$((k + 1))
done
await "$d" 3 $grip_pid && expect_word $A $LED5_OFF 577 "high pulse 900 on channel 5 is replaced by the expected 577 (GRIP failsafe)"
stub_set $A $LED5_OFF 0x41  # anything but the safe state
kill -KILL "$(cat "$d/pid")"
ack "$d" 3
wait $grip_pid
show "$LOGDIR/grip.out"
expect_word $A $LED5_OFF 420 "safe state on the adapter after the task is killed"

# --- a task that exits on its own --------------------------------------------
run_logged grip_exit under $MODE arm.policy gripper python3 $CLIENTS/gripper_seq.py 420 577
grep -q done "$OUT" && ok "gripper 420, 577 ran to its end (exit $RC)" || bad "gripper did not finish"
expect_word $A $LED5_OFF 420 "safe state on the adapter after the task exits"

stop_monitor
[ "$MODE" = monitor ] && expect_word $A $LED5_OFF 420 "safe state after the monitor stops"
show_audit_summary
finish
