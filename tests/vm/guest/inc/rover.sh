# policies/rover.policy: GoPiGo2 frames from the follower task reach the stub
# (0x08) as the frames the device expects; spoofed ones do not. Mode $MODE,
# client library $LIB (smbus, smbus2, periphery).
#
# The line follower (the sensor the invariants read) is moved to a virtual
# bus 2 with contego's device model: i2c-stub is a register file, and the
# follower's request/reply exchange (write 01 03 00 00 00, then 10 bytes by
# receive-byte) would read back its own request bytes. The model reads the
# middle of the line, so INV3 applies: speeds 80 and forward.
. /vm/lib.sh
sed 's/line_follower at i2c-1/line_follower at i2c-2/' $POLICIES/rover.policy >$POLICIES/rover-vm.policy
BUS_ARGS="$BUS_ARGS --virtual-bus 2"

[ "$MODE" = monitor ] && { start_monitor rover-vm.policy || finish; }

d=$(sync_dir)
#        set_left_speed(80) set_right_speed(80) fwd()     spoof: speed 255  spoof: spin right  digital_write
frames="1:70,80,0,0        1:71,80,0,0         1:105,0,0,0 1:70,255,0,0     1:110,0,0,0        1:12,9,1,0"
echo "  \$ frames.py $LIB --sync $d 0x08 $frames (under contego, background)"
under $MODE rover-vm.policy follower python3 $CLIENTS/frames.py $LIB --sync "$d" 0x08 $frames \
  >"$LOGDIR/frames.out" 2>&1 &
pid=$!
step() {  # step K EXPECTED DESCRIPTION
  await "$d" $1 || return 1
  expect_frame "$2" "$3"
  gopigo_clear
  ack "$d" $1
}
gopigo_clear
step 0 "46 50 00 00" "allowed set_left_speed(80) lands as I2C block 46 50 00 00 at reg 1"
step 1 "47 50 00 00" "allowed set_right_speed(80) lands"
step 2 "69 00 00 00" "allowed fwd() lands"
step 3 "46 50 00 00" "spoofed set_left_speed(255) does not land: replaced by speed 80 (INV3)"
await "$d" 4 && {
  got=$(gopigo_frame)
  case "$got" in
    "69 00 00 00"|"77 00 00 00") ok "spoofed right_rot() does not land: replaced by fwd() (stub: $got)" ;;
    *) bad "spoofed right_rot(): stub shows $got, expected fwd()" ;;
  esac
  gopigo_clear; ack "$d" 4
}
step 5 "00 00 00 00" "forbidden digital_write(9, 1) does not reach the stub"
wait $pid
show "$LOGDIR/frames.out"
grep -q "frame 5 refused 1" "$LOGDIR/frames.out" && ok "digital_write fails with EPERM in the program" ||
  bad "digital_write was not refused with EPERM"
grep -q done "$LOGDIR/frames.out" && ok "the $LIB client ran to its end" || bad "the $LIB client did not finish"
expect_frame "78 00 00 00" "safe state stop() on the stub after the task exits"
stop_monitor
show_audit_summary
finish
