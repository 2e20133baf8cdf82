# The real i2c-tools under contego (mode $MODE), as policies/arm.policy's
# arm_init task (it may write and read the PCA9685 at 0x40). Each result is
# compared with what the kernel shows outside contego.
. /vm/lib.sh
A=0x40
stub_set $A 0x00 0x11  # MODE1 as out of reset: asleep, so PRE_SCALE takes writes
[ "$MODE" = monitor ] && { start_monitor arm.policy || finish; }

# contego hands programs the adapter's real I2C_FUNCS: identical to outside.
i2cdetect -F 0 | tail -n +2 >"$LOGDIR/funcs-outside"
run_logged funcs under $MODE arm.policy arm_init i2cdetect -F 1
[ $RC = 0 ] && tail -n +2 "$OUT" | cmp -s - "$LOGDIR/funcs-outside" &&
  ok "i2cdetect -F 1 under contego lists the adapter's functionality as i2cdetect -F 0 does" ||
  bad "i2cdetect -F 1 under contego (exit $RC) differs from i2cdetect -F 0"

run_logged detect under $MODE arm.policy arm_init i2cdetect -y 1
[ $RC = 0 ] && ok "i2cdetect -y 1 runs to its end under contego" || bad "i2cdetect -y 1 exit $RC"
grep -q "^40: *40\|^40:.*40" "$OUT" && ok "i2cdetect -y 1 sees the PCA9685 at 0x40" ||
  bad "i2cdetect -y 1 does not show 0x40"
# Probing must not write anything: i2cdetect's quick writes to chips the task
# may not command are refused by contego, and the ones it may are no-ops.
# ALL_LED_OFF_H = 0 (Adafruit's init writes it; LEDn writes are checked
# against the power-on full-off bit, so a lone LED0_ON_L write is ignored).
stub_set $A 0xfd 0x11
run_logged set under $MODE arm.policy arm_init i2cset -y 1 $A 0xfd 0x00
[ $RC = 0 ] && ok "i2cset -y 1 0x40 0xfd 0x00 exits 0" || bad "i2cset exit $RC"
expect_reg $A 0xfd 0x00 "i2cset lands on the stub"

stub_set $A 0xfe 0x79
run_logged get under $MODE arm.policy arm_init i2cget -y 1 $A 0xfe
[ "$(cat "$OUT")" = 0x79 ] && ok "i2cget -y 1 0x40 0xfe reads the stub's 0x79 through contego" ||
  bad "i2cget under contego read '$(cat "$OUT")', the stub has 0x79"

run_logged dump under $MODE arm.policy arm_init i2cdump -y 1 $A b
snapshot $A >"$LOGDIR/dump-outside"
# i2cdump's header names the bus and chip; compare the 16 data rows only
grep '^[0-9a-f]0:' "$OUT" >"$LOGDIR/dump-in"
grep '^[0-9a-f]0:' "$LOGDIR/dump-outside" >"$LOGDIR/dump-out"
[ $RC = 0 ] && [ -s "$LOGDIR/dump-in" ] && cmp -s "$LOGDIR/dump-in" "$LOGDIR/dump-out" &&
  ok "i2cdump -y 1 0x40 under contego equals i2cdump -y 0 0x40 outside" ||
  { bad "i2cdump under contego differs from outside"; diff "$LOGDIR/dump-in" "$LOGDIR/dump-out"; }

# i2ctransfer speaks I2C_RDWR only and checks I2C_FUNCS first: on i2c-stub
# (no plain I2C) it must refuse under contego exactly as on the bare node,
# and nothing may land. (python3-periphery's I2C_RDWR, which does not ask,
# is carried as SMBus by contego: see the rover scenarios.)
i2ctransfer -y 0 w2@$A 0xfe 3 >"$LOGDIR/xfer-outside" 2>&1
rc_out=$?
run_logged xfer_w under $MODE arm.policy arm_init i2ctransfer -y 1 w2@$A 0xfe 3
[ $RC != 0 ] && [ $rc_out != 0 ] && grep -q "I2C transfers" "$OUT" &&
  ok "i2ctransfer refuses the SMBus-only adapter under contego as outside (exit $RC / $rc_out)" ||
  bad "i2ctransfer under contego: exit $RC, outside: exit $rc_out"
expect_reg $A 0xfe 0x79 "nothing of i2ctransfer lands"
run_logged set101 under $MODE arm.policy arm_init i2cset -y 1 $A 0xfe 101
expect_reg $A 0xfe 101 "i2cset PRE_SCALE=101 lands"

# The same as the gripper task: python3-smbus2 (the end-to-end tests' script)
run_logged grip under $MODE arm.policy gripper python3 $CLIENTS/gripper_smbus2.py
# arm.policy ignores the gripper's configuration writes (a vendor constructor
# must run): the program is told PRE_SCALE was written; the register says not.
grep -q "pulse sent" "$OUT" && grep -q "prescale written" "$OUT" &&
  ok "gripper_smbus2.py: pulse sent, PRE_SCALE ignored (reported written)" || bad "gripper_smbus2.py output"
expect_reg $A 0xfe 101 "the gripper's PRE_SCALE=3 does not land"
expect_word $A 0x1c 420 "gripper LED5 off = 420 on the stub"

# An address the policy does not name: refused, nothing reaches chip 0x48.
stub_set 0x48 0x01 0x22
run_logged other under $MODE arm.policy arm_init i2cset -y 1 0x48 0x01 0x55
[ $RC != 0 ] && ok "i2cset to 0x48 (not in the policy) fails (exit $RC)" || bad "i2cset to 0x48 reported success"
expect_reg 0x48 0x01 0x22 "nothing reaches chip 0x48"

# python3-smbus reading and writing the PCA9685 as arm_init
cat >/tmp/smbus_rw.py <<'PY'
import smbus
bus = smbus.SMBus(1)
bus.write_byte_data(0x40, 0x01, 0x04)  # MODE2: totem pole, as Adafruit's init
print("mode2", hex(bus.read_byte_data(0x40, 0x01)))
PY
run_logged smbus under $MODE arm.policy arm_init python3 /tmp/smbus_rw.py
grep -q "mode2 0x4" "$OUT" && ok "python3-smbus writes and reads MODE2 through contego" || bad "python3-smbus MODE2"
expect_reg $A 0x01 0x04 "python3-smbus's MODE2=0x04 lands"

# python3-periphery insists on plain I2C (it checks I2C_FUNCS): it must
# refuse the SMBus-only stub under contego exactly as on the bare node.
cat >/tmp/periphery_open.py <<'PY'
import sys
from periphery import I2C
try:
    I2C(sys.argv[1]).close()
    print("opened")
except Exception as e:
    print("refused:", str(e).replace(sys.argv[1], "NODE"))
PY
python3 /tmp/periphery_open.py $ADAPTER >"$LOGDIR/periphery-outside" 2>&1
run_logged periphery under $MODE arm.policy arm_init python3 /tmp/periphery_open.py /dev/i2c-1
grep -q "refused: .*I2C not supported" "$OUT" && cmp -s "$OUT" "$LOGDIR/periphery-outside" &&
  ok "python3-periphery refuses the SMBus-only adapter under contego as on the bare node" ||
  { bad "python3-periphery under contego differs from the bare node"; show "$LOGDIR/periphery-outside"; }

stop_monitor
show_audit_summary
finish
