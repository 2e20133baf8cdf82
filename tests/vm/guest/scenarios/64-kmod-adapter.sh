# contego.ko and an adapter that goes away and comes back while a session
# is open (docs/kernel-client.md, "Adapters that come and go"): the module's
# bus notifier takes the node away with its adapter (i2c-stub unloaded),
# nothing is written meanwhile, and an adapter added again under the same
# number gets its node back and its devices their safe state; both audited.
# The live session then ends on the returned adapter and drives it too.
. /vm/lib.sh
. /vm/inc/kmod.sh
kmod_built_or_skip
A=0x40
AUDIT_LOG=$LOGDIR/kmod-adapter.jsonl

rmmod i2c_dev || { bad "cannot unload i2c-dev"; finish; }
run_logged insmod insmod $KO adapters=0 buses=1
[ $RC = 0 ] || { bad "insmod contego.ko adapters=0 buses=1 (exit $RC)"; back_to_i2c_dev; finish; }
wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
start_reader || { back_to_i2c_dev; finish; }
run_logged load contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --bind gripper=contego \
  --budget-factor 0
[ $RC = 0 ] && ok "contego kmod load: arm.policy in force" || bad "contego kmod load (exit $RC)"

# MODE1 with auto-increment (0x21), as the vendor library sets it: a block
# write then fills LED5's four registers. (This call's own session ends with
# it: it drives the arm's safe state.)
run_logged mode1 as_task i2cset -y 0 $A 0x00 0x21
[ $RC = 0 ] && ok "arm_init: MODE1 = 0x21 (auto-increment)" || bad "MODE1 write (exit $RC)"
wait_sessions_closed

# A live session of arm_init: a script that set LED5 off = 577 and sleeps.
# It holds no descriptor of the node: only its session is open.
start_led5_holder
[ "$(led5)" = 577 ] && ok "a session of arm_init is open (pid $HOLDER), LED5 off = 577" ||
  { bad "LED5 off reads $(led5) with the session open, expected 577"; show "$LOGDIR/holder.out"; }
contego kmod stats | grep -q " sessions=1 " && ok "the module counts the session" ||
  bad "module counters: $(contego kmod stats)"

# The adapter goes away under the module.
klog_mark removal
rmmod i2c_stub && ok "i2c-stub unloads while contego.ko protects its adapter and a session is open" ||
  bad "rmmod i2c_stub (the module must not hold the adapter)"
i=0
while [ -e /dev/i2c-0 ] && [ $i -lt 50 ]; do i=$((i + 1)); usleep 100000; done
[ ! -e /dev/i2c-0 ] && ok "/dev/i2c-0 is gone with its adapter" || bad "/dev/i2c-0 outlived its adapter"
klog_since removal | grep -q "contego: adapter i2c-0 removed" && ok "the kernel log says the adapter was removed" ||
  bad "no removal line in the kernel log"
run_logged gone as_task i2cset -y 0 $A 0x01 0x04
[ $RC != 0 ] && ok "a write while the adapter is away fails (exit $RC): nothing is written" ||
  bad "i2cset succeeded with the adapter away"

# Back under the same number: a fresh chip (every register zero, MODE1's
# auto-increment off: the module reads the shadow back before it drives).
insmod /lib/modules/i2c-stub.ko chip_addr=$STUB_ADDRS && ok "i2c-stub loaded again" || bad "insmod i2c-stub"
wait_for /dev/i2c-0 10 && ok "/dev/i2c-0 is back with its adapter" || bad "no /dev/i2c-0 after the adapter came back"
chmod 0666 /dev/i2c-0
led5_becomes 420 && ok "the returned adapter's PCA9685 went to its safe state: LED5 off = 420" ||
  bad "after the adapter came back LED5 off reads $(led5), expected the safe state 420"
klog_since removal | grep -q "contego: adapter i2c-0 is back as the policy's bus 1: 1 devices driven to their safe state" &&
  ok "the kernel log says the adapter is back and its device was driven" || bad "no return line in the kernel log"
klog_since removal | grep -q "contego: device 0 (bus 1 0x40): shadow read back from the device" &&
  ok "the returned chip's registers were read back into the shadow" || bad "no shadow read back after the return"

# The session opened before the removal ends now: its end drives the arm on
# the returned adapter.
klog_mark kill
[ -n "$HOLDER" ] && kill -TERM "$HOLDER"
wait_sessions_closed && ok "the session opened before the removal ended after the return" ||
  bad "sessions still open: $(contego kmod stats)"
klog_since kill |
  grep -q "contego: task 0: session of pid [0-9]* ended (wait status 0x[0-9a-f]*, with its group's leader): 1 of 1 devices driven to their safe state" &&
  ok "its end drove the arm on the returned adapter" ||
  { bad "no session end driving the arm after the return"; dmesg | grep "contego: task" | tail -n 5; }
# The task has no live session now: a new process of it acts, checked.
run_logged again as_task i2cset -y 0 $A 0x01 0x04
[ $RC = 0 ] && [ "$(as_task i2cget -y 0 $A 0x01)" = 0x04 ] &&
  ok "arm_init writes MODE2 = 0x04 through the returned adapter, checked" || bad "write after the return (exit $RC)"

stop_reader && ok "contego kmod audit stops on SIGTERM" || bad "contego kmod audit exit $rc"
run_logged verify contego audit $AUDIT_LOG
[ $RC = 0 ] && ok "contego audit verifies the log" || bad "contego audit exit $RC"
for what in 'adapter i2c-0 (the policy.s bus 1) removed' 'adapter i2c-0 (the policy.s bus 1) back' \
    'its adapter came back' '"kind":"adapter"'; do
  grep -q "$what" $AUDIT_LOG && ok "the log has $what" || bad "the log lacks $what"
done

# A load while the adapter is away (a HAT powered after boot): refused
# strictly, in force with --allow-degraded, and `kmod status` says what it
# could not do until the adapter comes and its device is driven.
start_reader || { back_to_i2c_dev; finish; }
rmmod i2c_stub
run_logged away_load contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --budget-factor 0
[ $RC = 1 ] && grep -q "load refused: the safe state of arm (i2c-1 0x40) could not be driven" "$OUT" &&
  ok "a load with the adapter away is refused: $(cat "$OUT")" || bad "a load with the adapter away: exit $RC"
run_logged away_degraded contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --budget-factor 0 \
  --allow-degraded
[ $RC = 0 ] && ok "--allow-degraded loads it" || bad "kmod load --allow-degraded with the adapter away: exit $RC"
run_logged away_status contego kmod status
grep -q "^DEGRADED: the safe state of arm (i2c-1 0x40) not driven since the load (loaded with --allow-degraded)" "$OUT" &&
  contego kmod stats | grep -q " undriven=0x1 unread=0x0" &&
  ok "kmod status: $(grep DEGRADED "$OUT")" || bad "kmod status after the degraded load: $(cat "$OUT")"
run_logged away_json contego kmod status --json
python3 -c 'import json, sys; s = json.load(open(sys.argv[1])); assert s["degraded"].startswith("the safe state of arm"), s' \
  "$OUT" 2>/dev/null && ok "kmod status --json: the same under \"degraded\"" || bad "kmod status --json: $(cat "$OUT")"
# A load in place meanwhile checks the forms of the safe states it can:
# the adapter away is no new gap (its return drives them), so it is taken.
sed 's/^limit gripper -> arm.led 1 per job/limit gripper -> arm.led 2 per job/' $POLICIES/arm.policy >/tmp/arm-more.policy
run_logged away_reload contego kmod reload --policy /tmp/arm-more.policy --bind arm_init=task --budget-factor 0
[ $RC = 0 ] && contego kmod stats | grep -q " undriven=0x1 " &&
  ok "a load in place with the adapter away is taken, still degraded" || bad "kmod reload with the adapter away: exit $RC"
insmod /lib/modules/i2c-stub.ko chip_addr=$STUB_ADDRS && wait_for /dev/i2c-0 10 || bad "the adapter did not come back"
led5_becomes 420 && ok "the adapter came: the arm driven to its safe state (LED5 off = 420)" ||
  bad "after the adapter came LED5 off reads $(led5)"
run_logged back_status contego kmod status
! grep -q "DEGRADED" "$OUT" && contego kmod stats | grep -q " undriven=0x0 unread=0x0" &&
  ok "kmod status: no longer degraded once the arm was driven" || bad "kmod status after the adapter came: $(cat "$OUT")"
stop_reader
klog_since removal | grep -E "BUG|Oops|WARNING|general protection|refcount" >/tmp/klog.bad
[ -s /tmp/klog.bad ] && bad "kernel log: $(head -n 1 /tmp/klog.bad)" ||
  ok "no kernel warning through the removal and the return"
rmmod contego && ok "contego.ko unloads after its adapter came and went" || bad "rmmod contego"
back_to_i2c_dev
finish
