# contego refuses to start, with a message naming what is wrong, a non-zero
# exit, the program never run and nothing on the adapter, when the policy
# and the adapters do not fit: a device missing on its bus, a policy bus no
# --bus gives, an adapter path that does not exist or is no adapter, an
# unknown task, an unreachable monitor.
. /vm/lib.sh
A=0x40
# A policy whose arm (0x40, present) has a safe state, plus a second PCA9685
# at 0x41, which the stub does not have: a start that drove the arm's safe
# state before noticing the missing chip would show on 0x40.
cp $POLICIES/arm.policy $POLICIES/arm-missing.policy
echo 'device arm2 : pca9685 at i2c-1 0x41 { safe led(0, on=0, off=300) }' >>$POLICIES/arm-missing.policy

stub_set $A 0x1c 0x41  # LED5 off: anything but the safe state (420)
stub_set $A 0x1d 0x00
before=$(snapshot $A)
marker=/tmp/program-ran
rm -f $marker

refused() {  # refused LABEL PATTERN DESCRIPTION (after run_logged LABEL ...)
  if [ $RC != 0 ] && grep -qi -- "$2" "$OUT" && [ ! -e $marker ]; then
    ok "$3 (exit $RC)"
  else
    bad "$3 (exit $RC, message must match '$2', program must not run)"
  fi
  rm -f $marker
}
prog="sh -c 'touch $marker'"

run_logged missing sh -c "contego run --policy $POLICIES/arm-missing.policy $BUS_ARGS --task arm_init -- $prog"
refused missing "0x41" "run: device arm2 missing at 0x41 on i2c-1: refused, naming the address"
grep -q "arm2" "$OUT" && ok "the message names device arm2" || bad "the message does not name device arm2"

run_logged busmismatch sh -c "contego run --policy $POLICIES/arm.policy --bus 2=$ADAPTER --task arm_init -- $prog"
refused busmismatch "i2c-1\|bus 1" "run: policy bus i2c-1 without a --bus 1 (only 2 given): refused, naming bus 1"

# A bus descriptor the program would inherit from whoever starts `contego
# run` (fd 9 passed on with --pass-fd, or standard input) would reach the bus
# unchecked: refused before anything starts, naming it. (One left open and
# not passed is closed at exec: cli.inherited_fds.)
run_logged inherited_pass sh -c "exec 9<>$ADAPTER; contego run --policy $POLICIES/arm.policy $BUS_ARGS --task arm_init --user 1000 --pass-fd 9 -- $prog"
refused inherited_pass "descriptor 9 is an I2C bus node" "run: --pass-fd of a bus descriptor: refused"
run_logged inherited_stdin sh -c "contego run --policy $POLICIES/arm.policy $BUS_ARGS --task arm_init --user 1000 -- $prog <>$ADAPTER"
refused inherited_stdin "descriptor 0 is an I2C bus node" "run: a bus node as standard input: refused"

run_logged nonode sh -c "contego run --policy $POLICIES/arm.policy --bus 1=/dev/i2c-7 --task arm_init -- $prog"
refused nonode "/dev/i2c-7" "run: adapter /dev/i2c-7 does not exist: refused, naming it"

run_logged notadapter sh -c "contego run --policy $POLICIES/arm.policy --bus 1=/dev/null --task arm_init -- $prog"
refused notadapter "/dev/null" "run: /dev/null is not an i2c adapter: refused, naming it"

run_logged badtask sh -c "contego run --policy $POLICIES/arm.policy $BUS_ARGS --task nosuch -- $prog"
refused badtask "nosuch" "run: unknown task: refused, naming it"

# `timeout`: a monitor that wrongly starts would serve for ever.
mkdir -p /run/contego && chown $MONITOR_UID /run/contego
run_logged mon_missing timeout 30 su contego -s /bin/sh -c "contego monitor --policy $POLICIES/arm-missing.policy $BUS_ARGS --socket $SOCK"
refused mon_missing "0x41" "monitor: device arm2 missing at 0x41: refused"
[ ! -e $SOCK ] && ok "monitor: no socket after a refused start" || bad "monitor left a socket"
run_logged mon_bus timeout 30 su contego -s /bin/sh -c "contego monitor --policy $POLICIES/arm.policy --bus 2=$ADAPTER --socket $SOCK"
refused mon_bus "i2c-1\|bus 1" "monitor: policy bus i2c-1 not given: refused"

run_logged nosock as_task contego run --socket /run/contego/none.sock --task arm_init -- sh -c "touch $marker"
refused nosock "none.sock" "run --socket: no monitor there: refused before the program runs"

after=$(snapshot $A)
[ "$before" = "$after" ] && ok "nothing reached the PCA9685 in any refused start" ||
  { bad "the PCA9685 changed during refused starts"; echo "$after"; }
finish
