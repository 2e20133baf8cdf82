# One decision for both clients (docs/kernel-client.md): the same corpus of
# transfers (clients/parity_corpus.py: SMBus calls, raw writes after
# I2C_SLAVE, I2C_RDWR register reads; allowed, ignored, refused) sent as
# arm_init under policies/arm.policy, once through the monitor embedded in
# `contego run` and once through contego.ko, each time on a freshly loaded
# i2c-stub. Compared: what the program was told at every step, the decisions
# of the two audit logs (command, verdict, reason, rule, bytes) and every
# register of the chip afterwards (read through the plain i2c-dev).
. /vm/lib.sh
. /vm/inc/kmod.sh
kmod_built_or_skip
A=0x40

fresh_chip() {  # i2c-stub reloaded: every register 0, then PRE_SCALE as reset leaves it
  stub_reload || return 1
  stub_set $A 0xfe 0x1e
  stub_set $A 0x00 0x11
}

# --- the monitor, embedded in contego run ------------------------------------
fresh_chip || { bad "i2c-stub could not be reloaded"; finish; }
run_logged monitor_run contego run --policy $POLICIES/arm.policy $BUS_ARGS --user 1000 \
  --task arm_init --budget-factor 0 --audit $LOGDIR/monitor.jsonl \
  -- python3 $CLIENTS/parity_corpus.py 1
grep -v "^contego" "$OUT" >$LOGDIR/monitor.steps  # the program's lines, not contego run's own
snapshot $A >$LOGDIR/monitor.chip

# --- contego.ko -----------------------------------------------------------------
fresh_chip || { bad "i2c-stub could not be reloaded"; finish; }
rmmod i2c_dev
run_logged insmod insmod $KO adapters=0 buses=1
wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
AUDIT_LOG=$LOGDIR/kmod.jsonl
start_reader || finish
run_logged load contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --budget-factor 0
run_logged kmod_run as_task python3 $CLIENTS/parity_corpus.py 0
grep -v "^contego" "$OUT" >$LOGDIR/kmod.steps
wait_sessions_closed
stop_reader
back_to_i2c_dev
snapshot $A >$LOGDIR/kmod.chip

# --- compared ----------------------------------------------------------------------
grep -q "^done" $LOGDIR/monitor.steps && grep -q "^done" $LOGDIR/kmod.steps &&
  ok "the corpus ran to its end under both clients" || bad "the corpus did not finish under both"
if cmp -s $LOGDIR/monitor.steps $LOGDIR/kmod.steps; then
  ok "the program was told the same at each of its $(($(wc -l <$LOGDIR/kmod.steps) - 1)) steps"
else
  bad "the program was told different things:"; diff $LOGDIR/monitor.steps $LOGDIR/kmod.steps
fi
decisions $LOGDIR/monitor.jsonl arm_init >$LOGDIR/monitor.decisions
decisions $LOGDIR/kmod.jsonl arm_init >$LOGDIR/kmod.decisions
n=$(wc -l <$LOGDIR/kmod.decisions)
if [ "$n" -gt 10 ] && cmp -s $LOGDIR/monitor.decisions $LOGDIR/kmod.decisions; then
  ok "both logs hold the same $n decisions (command, verdict, reason, rule, bytes, fields): 0 mismatches"
else
  bad "the decisions differ ($n under contego.ko):"; diff $LOGDIR/monitor.decisions $LOGDIR/kmod.decisions
fi
if cmp -s $LOGDIR/monitor.chip $LOGDIR/kmod.chip; then
  ok "the chip's 256 registers are the same after both runs"
else
  bad "the chip differs:"; diff $LOGDIR/monitor.chip $LOGDIR/kmod.chip
fi
show $LOGDIR/kmod.steps
finish
