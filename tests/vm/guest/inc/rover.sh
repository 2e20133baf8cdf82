# policies/rover.policy: GoPiGo2 frames from the follower task reach the stub
# (0x08) as the frames the device expects; spoofed ones do not. Mode $MODE,
# client library $LIB (smbus, smbus2, periphery).
#
# The line follower (the sensor the invariants read) is moved to a virtual
# bus 2 with contego's device model: i2c-stub is a register file, and the
# follower's sample (write 01 03 00 00 00, then a 10-byte read with no
# register byte) has no SMBus form. The model reads 512 on all five sensors
# (white, below the vendor calibration), for which the policy's position is
# above THETA: INV2 applies, so the vendor loop's frames are speeds 125 and
# left() (`contego test` agrees).
. /vm/lib.sh
sed 's/line_follower at i2c-1/line_follower at i2c-2/' $POLICIES/rover.policy >$POLICIES/rover-vm.policy
BUS_ARGS="$BUS_ARGS --virtual-bus 2"

[ "$MODE" = monitor ] && { start_monitor rover-vm.policy || finish; }

d=$(sync_dir)
#        set_left_speed(125) set_right_speed(125) left()     spoof: speed 255  spoof: spin right  digital_write
frames="1:70,125,0,0        1:71,125,0,0         1:97,0,0,0 1:70,255,0,0     1:110,0,0,0        1:12,9,1,0"
echo "  \$ frames.py $LIB --sync $d 0x08 $frames (under contego, background)"
under $MODE rover-vm.policy follower python3 $CLIENTS/frames.py $LIB --sync "$d" 0x08 $frames \
  >"$LOGDIR/frames.out" 2>&1 &
pid=$!
step() {  # step K EXPECTED DESCRIPTION
  await "$d" $1 $pid || return 1
  expect_frame "$2" "$3"
  gopigo_clear
  ack "$d" $1
}
gopigo_clear
step 0 "46 7d 00 00" "allowed set_left_speed(125) lands as I2C block 46 7d 00 00 at reg 1"
step 1 "47 7d 00 00" "allowed set_right_speed(125) lands"
step 2 "61 00 00 00" "allowed left() lands"
step 3 "46 7d 00 00" "spoofed set_left_speed(255) does not land: replaced by speed 125 (INV2)"
step 4 "61 00 00 00" "spoofed right_rot() does not land: replaced by left() (INV2)"
# The safe state stop() is sent in the firmware's 4-byte framing (78 00 00
# 00: the firmware takes the last four bytes of any write as the frame), which
# i2c-stub stores as an I2C-block write of 00 00 00 at register 0x78: mark
# those registers to see it land.
for r in 0x78 0x79 0x7a; do stub_set 0x08 $r 0xee; done
step 5 "00 00 00 00" "forbidden digital_write(9, 1) does not reach the stub"
wait $pid
show "$LOGDIR/frames.out"
grep -q "frame 5 refused 1" "$LOGDIR/frames.out" && ok "digital_write fails with EPERM in the program" ||
  bad "digital_write was not refused with EPERM"
grep -q done "$LOGDIR/frames.out" && ok "the $LIB client ran to its end" || bad "the $LIB client did not finish"
got=$(for r in 0x78 0x79 0x7a; do printf '%02x ' $(( $(stub_get 0x08 $r) )); done)
[ "$got" = "00 00 00 " ] && ok "safe state stop() (78 00 00 00) on the stub after the task exits" ||
  { bad "no safe state stop() on the stub after the task exits (regs 0x78.. = $got)"; i2cdump -y 0 0x08 b; }
stop_monitor
show_audit_summary
finish
