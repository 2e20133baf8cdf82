# The plain-I2C path on a real kernel: a second adapter, i2c-plain-stub
# (tests/vm/kmod: I2C_FUNC_I2C with the kernel's SMBus emulation, register-file
# chips behind master_xfer), as i2c-1 beside i2c-stub's i2c-0; the
# Raspberry Pi's controller is such an adapter. On it:
#  (a) contego.ko (adapters=1 buses=1, so its node is /dev/i2c-1, the one the
#      policies and the attack programs name) against the attack programs of
#      tests/intercept (a buffer rewritten by a second thread during write(),
#      a timer storm during 3000 writes, a static binary with FORCE, raw
#      syscalls, dup2, fork, a write smuggled into a combined transfer and an
#      exec'd i2cset, another process under a dead one's pid, the node opened
#      by other names and through a node made with mknod, a CLONE_FILES
#      sibling's close), a policy of its own (ATTACK_POLICY below);
#      i2ctransfer, python3-periphery and plain read()/write(); then
#      arm.policy's gripper and attack_rdwr_atomic (combined transfers with a
#      forbidden second message, general call, reserved and 10-bit
#      addresses), and a sensor sampled by the module with a combined
#      write-then-read (tank.policy);
#  (b) `contego monitor --bus 1=/dev/i2c-1` and `contego run --socket`: the
#      monitor performs on the adapter with I2C_RDWR (not the SMBus plan):
#      arm_init's combined i2ctransfer, the gripper's attack_rdwr_atomic;
#      the monitor's own sampling of the tank (tank.policy).
# Everything is read back through the plain i2c-dev, outside contego (after
# contego.ko is unloaded, after the monitor stopped).
. /vm/lib.sh
. /vm/inc/kmod.sh
PLAIN=/lib/modules/i2c-plain-stub.ko
for m in $KO $PLAIN; do
  if [ ! -f $m ]; then
    # Not a failure: the host had no linux-headers for this kernel (tools/bootstrap.sh).
    echo "VM-CHECK SKIP $SCENARIO: ${m##*/} was not built (no kernel headers on the host)"
    exit 0
  fi
done
ATTACK=/vm/attack
if [ ! -x $ATTACK/attack_static ]; then
  bad "no attack programs in $ATTACK (run.sh --attack-binary; build tests/intercept's attack_* targets)"
  finish
fi
A=0x40
# Outside contego: the plain adapter through i2c-dev.
plain_get() { i2cget -y 1 "$1" "$2" b; }
plain_set() { i2cset -y 1 "$1" "$2" "$3" b; }
plain_expect() {  # plain_expect ADDR REG VALUE DESCRIPTION
  got=$(plain_get "$1" "$2")  # a failed read is no value, never 0
  if [ -n "$got" ] && [ $((got)) = $(($3)) ]; then ok "$4 (reg $2 = $got)"; else bad "$4 (reg $2 = $got, expected $3)"; fi
}
plain_word() { lo=$(plain_get "$1" "$2") && hi=$(plain_get "$1" $(($2 + 1))) && echo $(((hi << 8) | lo)); }
unload_plain() { rmmod i2c_plain_stub; }  # i2c-dev is loaded whenever it is called

# The arm (0x40), and tank.policy's buzzer, tank and display (0x20, 0x48,
# 0x3c): the monitor refuses to start when a policy device does not answer.
run_logged plain_insmod insmod $PLAIN chip_addr=$A,0x20,0x48,0x3c
[ $RC = 0 ] || { bad "insmod i2c-plain-stub (exit $RC)"; finish; }
BUS=
for d in /sys/bus/i2c/devices/i2c-*; do
  [ "$(cat "$d/name" 2>/dev/null)" = i2c-plain-stub ] && BUS=${d##*/i2c-}
done
if [ "$BUS" = 1 ] && wait_for /dev/i2c-1 10; then
  ok "i2c-plain-stub is adapter 1 (/dev/i2c-1), beside i2c-stub's 0"
else
  bad "i2c-plain-stub is adapter '$BUS', not 1, or has no node"
  unload_plain
  finish
fi

# The adapter itself, bare.
run_logged funcs i2cdetect -F 1
grep -q '^I2C  *yes' "$OUT" && grep -q '^SMBus Write Byte  *yes' "$OUT" &&
  ok "i2cdetect -F 1: plain I2C, and SMBus by the kernel's emulation" || bad "i2cdetect -F 1"
run_logged bare_xfer i2ctransfer -y 1 w3@0x48 0x10 0x11 0x22 w1@0x48 0x10 r2
[ "$(cat "$OUT")" = "0x11 0x22" ] &&
  ok "bare: one I2C_RDWR (write with auto-increment, register byte, repeated-start read) reads back 0x11 0x22" ||
  bad "bare combined transfer read '$(cat "$OUT")'"
run_logged bare_nak i2cget -y 1 0x41 0x00
[ $RC != 0 ] && ok "bare: no chip at 0x41, no acknowledge (exit $RC)" || bad "i2cget of 0x41 succeeded"

# Protocol mangling, bare: the stub clocks a read with I2C_M_REV_DIR_ADDR as
# a bit-banged adapter does, a write of 0xff to register 0xff. This is what
# contego refuses below (contego/i2c_msg_flags.h), at every client.
run_logged bare_mangle $ATTACK/attack_msg_flags /dev/i2c-1 0x48 reads
grep -q '^read-rev-dir-addr 2 0' "$OUT" && [ "$(plain_get 0x48 0xff)" = 0xff ] &&
  ok "bare: a register read with I2C_M_REV_DIR_ADDR acts as a write (0x48 register 0xff = 0xff)" ||
  bad "bare: the mangled read did not write (register 0xff = $(plain_get 0x48 0xff))"
plain_set 0x48 0xff 0
plain_set $A 0xff 0
check_mangling() {  # the lines of attack_msg_flags (policy_e2e_test's)
  for f in nostart rev-dir-addr ignore-nak no-rd-ack stop dma-safe unknown; do
    for s in read lone-read write; do
      grep -q "^$s-$f -1 22\$" "$OUT" || { bad "$1: no '$s-$f -1 22'"; return 1; }
    done
  done
  grep -q '^read-plain 2 0$' "$OUT" || { bad "$1: the plain read failed"; return 1; }
  ok "$1: every read and write with a flag outside the allow-list refused (EINVAL), the plain read answered"
}

# Known values before contego.ko: PRE_SCALE as out of reset (30); the tank
# (0x48) at a level of 900 mm, 20.0 degC, for the sensor round.
plain_set $A 0xfe 0x1e
plain_set 0x48 0x00 $((900 >> 8)); plain_set 0x48 0x01 $((900 & 0xff))
plain_set 0x48 0x02 0; plain_set 0x48 0x03 200

# The attack programs' policy: the chip at 0x40 as a register map whose
# registers 0x06..0x0b the attacker may write and read (0x0c, a query
# register, makes the chip readable), 0x00..0x05 (MODE1 ...) and PRE_SCALE
# (0xfe) never. The attacker is uid 1000 and root (the pid-reuse
# attack needs CAP_SYS_ADMIN).
ATTACK_POLICY=/tmp/attack.policy
cat >$ATTACK_POLICY <<'POLICY'
device chip : regmap at i2c-1 0x40 {
  register 0x06 r06 : u8
  register 0x07 r07 : u8
  register 0x08 r08 : u8
  register 0x09 r09 : u8
  register 0x0a r0a : u8
  register 0x0b r0b : u8
  query register 0x0c id : u8
  forbid 0x00..0x05
  forbid 0xFE..0xFF
}
task attacker {
  period 1s; deadline 1s; wcet 10ms; priority 1
}
allow attacker -> chip
allow attacker reads chip
POLICY

swap_in() {  # contego.ko in place of i2c-dev, checking adapter 1 as the policy's bus 1
  rmmod i2c_dev || { bad "cannot unload i2c-dev"; return 1; }
  run_logged insmod$1 insmod $KO adapters=1 buses=1
  [ $RC = 0 ] && wait_for /dev/i2c-1 10 && chmod 0666 /dev/i2c-1
}
AUDIT_LOG=$LOGDIR/kmod-attack.jsonl
swap_in 1 && [ ! -e /dev/i2c-0 ] && ok "contego.ko checks adapter 1 (/dev/i2c-1) as the policy's bus 1" ||
  bad "contego.ko in place of i2c-dev"
start_reader $ATTACK_POLICY
# The race and the storm send thousands of writes within a second: the
# over-budget hold (scenario 60 tests it) is off for the attacks.
run_logged load contego kmod load --policy $ATTACK_POLICY --bind attacker=task --bind attacker=root \
  --budget-factor 0
[ $RC = 0 ] && ok "contego kmod load: the attack policy in force" || bad "kmod load of the attack policy (exit $RC)"

# A second thread rewrites write()'s buffer between 06 10 (allowed) and
# fe 03 (PRE_SCALE, forbidden) during 2000 writes: what is checked is what
# is sent (the audit lines, below; PRE_SCALE on the chip after the unload).
run_logged race as_task $ATTACK/attack_rdwr_race
race_ok=$(cat "$OUT")
[ $RC = 0 ] && [ "$race_ok" -gt 0 ] 2>/dev/null && [ "$race_ok" -le 2000 ] &&
  ok "attack_rdwr_race: $race_ok of 2000 writes of a buffer rewritten by a second thread reported success" ||
  bad "attack_rdwr_race (exit $RC, '$race_ok')"

# A timer every 20 us (slower where the CPU is emulated: the program widens
# it) during 3000 writes of register 0x06: each write acts
# once, and only when it reports success (counted against the audit lines).
storm_ok=0
for mode in eintr restart; do
  run_logged storm_$mode as_task $ATTACK/attack_signal_storm $mode
  line=$(grep '^ok ' "$OUT")
  n=$(echo "$line" | awk '{ print $2 }') e=$(echo "$line" | awk '{ print $4 }')
  if [ $RC = 0 ] && [ -n "$n" ] && [ $((n + e)) = 3000 ]; then
    ok "attack_signal_storm $mode: $line"
    storm_ok=$((storm_ok + n))
  else
    bad "attack_signal_storm $mode (exit $RC): $line"
  fi
done
grep -q '^ok 3000 ' "$LOGDIR/storm_restart.out" && ok "with SA_RESTART every one of the 3000 writes succeeded" ||
  bad "with SA_RESTART not every write succeeded"

# A static binary (no loader, no preload): FORCE, a forbidden write by
# write() and by raw syscall, the all-call address, a write smuggled into a
# combined transfer, dup2 and dup, fork, exec of i2cset. Nothing it tries
# may act; the exec'd i2cset is refused (exit 1).
run_logged static as_task $ATTACK/attack_static
static_acted=$(grep -E '^(write|raw-write|rdwr-smuggle)' "$OUT" | grep -v ' -1 ')
grep -q '^slave-force 0 0' "$OUT" && grep -q '^fork-child-denied 0 0' "$OUT" && [ $RC = 1 ] && [ -z "$static_acted" ] &&
  ok "attack_static: FORCE accepted, every write, the smuggled transfer, the child's and the exec'd i2cset's refused" ||
  bad "attack_static (exit $RC): ${static_acted:-see above}"

# Another process under a dead one's pid uses the descriptor number it held.
run_logged reuse $ATTACK/attack_pid_reuse
{ grep -q '^reuse-write -1 9' "$OUT" || grep -q '^reuse-skipped' "$OUT"; } && [ $RC = 0 ] &&
  ok "attack_pid_reuse: $(grep -E '^reuse-(write|skipped)' "$OUT")" || bad "attack_pid_reuse (exit $RC)"

# The node by other names, and a node made by hand (mknod 89:1: the same
# device, so contego.ko's): MODE1 = 0x31 (sleep) is refused with EPERM each
# time. A CLONE_FILES sibling closes the descriptor: the write gets EBADF.
mkdir -p /tmp/alt && mknod /tmp/alt/i2c-1 c 89 1 && chmod 0666 /tmp/alt/i2c-1 && chmod 0777 /tmp/alt
names_ok=""
for how in proc-self thread-self openat2-in-root symlink dotdot; do
  run_logged open_$how as_task $ATTACK/attack_identity open $how /tmp/alt
  [ $RC = 0 ] && names_ok="$names_ok $how" || bad "attack_identity open $how (exit $RC)"
done
[ -n "$names_ok" ] && ok "the mknod'ed node opened by other names ($names_ok ): MODE1 = 0x31 refused (EPERM)"
run_logged clone_files as_task $ATTACK/attack_identity clone-files
[ $RC = 0 ] && ok "attack_identity clone-files: the write on the closed descriptor fails (EBADF)" ||
  bad "attack_identity clone-files (exit $RC)"
rm -rf /tmp/alt

# Plain-I2C clients: i2ctransfer (one I2C_RDWR: a write, then the register
# byte and a repeated-start read), python3-periphery (I2C_RDWR) and plain
# write()/read() on the node.
run_logged xfer as_task i2ctransfer -y 1 w2@$A 0x08 0x5a w1@$A 0x08 r1
[ $RC = 0 ] && [ "$(cat "$OUT")" = 0x5a ] &&
  ok "i2ctransfer: write 0x08 = 0x5a and read it back in one combined transfer through contego.ko" ||
  bad "i2ctransfer combined (exit $RC, read '$(cat "$OUT")')"
run_logged xfer_bad as_task i2ctransfer -y 1 w2@$A 0x08 0x11 w2@$A 0xfe 0x03
[ $RC != 0 ] && ok "i2ctransfer: an allowed write combined with a forbidden one is refused as a whole (exit $RC)" ||
  bad "i2ctransfer with a forbidden second message succeeded"
cat >/tmp/plain_clients.py <<'PY'
import errno, fcntl, os
from periphery import I2C
i2c = I2C("/dev/i2c-1")
i2c.transfer(0x40, [I2C.Message([0x09, 0x33])])
msgs = [I2C.Message([0x09]), I2C.Message([0], read=True)]
i2c.transfer(0x40, msgs)
print("periphery 0x%02x" % msgs[1].data[0], flush=True)
i2c.close()
fd = os.open("/dev/i2c-1", os.O_RDWR)
fcntl.ioctl(fd, 0x0703, 0x40)  # I2C_SLAVE
os.write(fd, bytes([0x0A, 0x44]))
os.write(fd, bytes([0x0A]))
print("read 0x%02x" % os.read(fd, 1)[0], flush=True)
try:
    os.write(fd, bytes([0xFE, 0x03]))
    print("prescale written", flush=True)
except OSError as e:
    print("prescale refused", errno.errorcode[e.errno], flush=True)
PY
run_logged py as_task python3 /tmp/plain_clients.py
grep -q '^periphery 0x33' "$OUT" && ok "python3-periphery: I2C_RDWR write and combined read through contego.ko" ||
  bad "python3-periphery"
grep -q '^read 0x44' "$OUT" && ok "plain write() and read() on the node through contego.ko" || bad "plain write()/read()"
grep -q '^prescale refused EPERM' "$OUT" && ok "plain write() of PRE_SCALE refused (EPERM)" ||
  bad "plain write() of PRE_SCALE: $(grep prescale "$OUT")"

# The reader writes every record before it exits. (Its hash chain is
# verified in scenario 60: `contego audit` of these 8000 lines would take
# half a minute under TCG.)
stop_reader && ok "contego kmod audit stops (exit 0)" || bad "contego kmod audit exit $rc"
# Every write of register 0x06 that reported success has its allow line,
# and no other write of it was allowed; no write of PRE_SCALE was allowed.
allowed06=$(grep '"decision":"allow"' $AUDIT_LOG | grep -c '"bytes":"06 ')
prescale=$(grep '"decision":"allow"' $AUDIT_LOG | grep -c '"bytes":"fe')
[ "$allowed06" = $((race_ok + storm_ok)) ] &&
  ok "allow lines for register 0x06: $allowed06 = $race_ok (race) + $storm_ok (storm) writes that reported success" ||
  bad "allow lines for register 0x06: $allowed06, writes that reported success: $race_ok + $storm_ok"
[ "$prescale" = 0 ] && ok "no write of PRE_SCALE allowed" || bad "$prescale writes of PRE_SCALE allowed"

# ---- arm.policy on the plain adapter: the gripper's combined transfers ----
back_to_i2c_dev
AUDIT_LOG=$LOGDIR/kmod-arm.jsonl
swap_in 2
start_reader
run_logged load_arm contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --bind gripper=contego
[ $RC = 0 ] && ok "contego kmod load: arm.policy" || bad "kmod load arm.policy (exit $RC)"
# MODE1 = AI | ALLCALL, as Adafruit's init: the core decodes the gripper's
# 5-byte writes as whole LED groups (the stub always auto-increments).
run_logged mode1 as_task i2cset -y 1 $A 0x00 0x21
[ $RC = 0 ] && ok "arm_init: i2cset MODE1=0x21 through contego.ko (SMBus emulated on master_xfer)" ||
  bad "arm_init: MODE1 (exit $RC)"
check_atomic() {  # the lines of attack_rdwr_atomic under arm.policy's gripper (policy_e2e_test's)
  for line in "rdwr-led3-prescale 2 0" "rdwr-grip-prescale 2 0" "general-call 1 0" "reserved -1 6" \
      "ten-bit -1 " "pulse 5 0"; do
    grep -q "^$line" "$OUT" || { bad "$1: no '$line'"; return 1; }
  done
  ok "$1: both combined transfers with a forbidden PRE_SCALE ignored as a whole, general call ignored, reserved and 10-bit addresses refused, then the pulse 420 allowed"
}
run_logged atomic su contego -s /bin/sh -c "cd /tmp && exec $ATTACK/attack_rdwr_atomic"
check_atomic "attack_rdwr_atomic as the gripper, contego.ko"
run_logged mangle su contego -s /bin/sh -c "cd /tmp && exec $ATTACK/attack_msg_flags"
check_mangling "attack_msg_flags as the gripper, contego.ko"
# A 32-bit program (i386 on this x86-64 kernel, as armhf on a Pi's arm64
# one): every i2c ioctl goes through contego.ko's compat_ioctl, checked alike.
if [ -x $ATTACK/attack_compat32 ]; then
  run_logged compat32 su contego -s /bin/sh -c "cd /tmp && exec $ATTACK/attack_compat32"
  missing=
  for line in "funcs 0 1" "slave 0" "smbus-read 0 33" "rdwr-read 2 33" "rdwr-mangled -22" \
      "smbus-prescale 0" "rdwr-prescale 1"; do
    grep -q "^$line\$" "$OUT" || missing="$missing '$line'"
  done
  [ -z "$missing" ] && ok "32-bit program through compat_ioctl: funcs, register reads by SMBus and I2C_RDWR (MODE1 0x21), mangled read refused, PRE_SCALE writes ignored" ||
    bad "32-bit program through compat_ioctl: missing$missing"
else
  echo "VM-CHECK SKIP $SCENARIO: no 32-bit test program (built on x86-64 hosts only)"
fi
stop_reader
missing=
grep -q '"bytes":"1a 00 00 a4 01".*"decision":"allow"' $AUDIT_LOG || missing="$missing the-pulse"
grep -q '"reason_name":"general-call"' $AUDIT_LOG || missing="$missing general-call"
grep -q '"reason_name":"transfer-dropped"' $AUDIT_LOG || missing="$missing transfer-dropped"
if [ -z "$missing" ]; then
  ok "the module's log: the pulse allowed, the transfers dropped, the general call ignored"
else
  bad "the module's log lacks:$missing"
  grep -a '"kind":"decision"' $AUDIT_LOG | tail -n 12 | sed 's/^/    | /'
fi

# A sensor read by the module on the plain adapter: the tank's sample is
# one combined transfer (write [0x00], repeated-start read of 4 bytes). At
# 900 mm INV_W lets the buzzer's tone(1) land; had the sample failed, it
# would have been ignored (signal-unavailable).
AUDIT_LOG=$LOGDIR/kmod-tank.jsonl
start_reader $POLICIES/tank.policy
run_logged load_tank contego kmod load --policy $POLICIES/tank.policy --bind monitor=task
run_logged tone as_task i2cset -y 1 0x20 0x01 1
run_logged tank_stats contego kmod stats
[ $RC = 0 ] && grep -q "samples=[1-9].* sample_errors=0" "$OUT" &&
  ok "tank.policy: the module sampled the tank by a combined I2C transfer, no sample error" ||
  bad "the tank's samples: $(cat "$OUT")"
stop_reader

back_to_i2c_dev
wait_for /dev/i2c-1 10
plain_expect $A 0xfe 0x1e "PRE_SCALE untouched by every attack (race, static, smuggled, combined, plain write)"
plain_expect $A 0x06 0xb7 "register 0x06: the storm's last write (2999 & 0xff)"
plain_expect $A 0x07 0 "register 0x07: the pid-reuse write did not land"
plain_expect $A 0x08 0x5a "register 0x08: i2ctransfer's write landed, the refused combined one did not"
plain_expect $A 0x09 0x33 "register 0x09: python3-periphery's write landed"
plain_expect $A 0x0a 0x44 "register 0x0a: the plain write() landed"
plain_expect $A 0x00 0x21 "MODE1 = 0x21: arm_init's landed, MODE1 = 0x31 (sleep) and the general call's reset did not"
plain_expect $A 0x14 0 "LED3 off: the gripper's refused transfer did not land"
plain_expect $A 0xff 0 "register 0xff: no mangled read acted as a write under contego.ko"
[ "$(plain_word $A 0x1c)" = 420 ] && ok "LED5 off = 420 (the gripper's pulse and safe state)" ||
  bad "LED5 off = $(plain_word $A 0x1c), expected 420"
plain_expect 0x20 0x01 1 "the buzzer's tone(1) landed (the tank sampled at 900 mm)"

# ---- (b) the monitor on the plain adapter: I2C_RDWR, not the SMBus plan ----
chown $MONITOR_UID:$MONITOR_UID /dev/i2c-1 && chmod 0600 /dev/i2c-1
BUS_ARGS="--bus 1=/dev/i2c-1"
if start_monitor arm.policy; then
  # As set_pwm_freq: sleep (PRE_SCALE takes writes only so), PRE_SCALE, wake.
  run_logged mon_xfer under monitor arm.policy arm_init i2ctransfer -y 1 w2@$A 0x00 0x31 \
    w2@$A 0xfe 0x65 w2@$A 0x00 0x21 w1@$A 0xfe r1
  [ $RC = 0 ] && [ "$(tail -n 1 "$OUT")" = 0x65 ] &&
    ok "monitor: arm_init's i2ctransfer sleeps, writes PRE_SCALE=101, wakes and reads it back in one combined transfer" ||
    bad "monitor: arm_init's combined i2ctransfer (exit $RC)"
  run_logged mon_xfer3 under monitor arm.policy arm_init i2ctransfer -y 1 w2@$A 0xfe 0x03
  [ $RC = 0 ] && ok "monitor: arm_init's PRE_SCALE=3 by i2ctransfer exits 0 (ignored)" ||
    bad "monitor: PRE_SCALE=3 (exit $RC)"
  run_logged mon_atomic under monitor arm.policy gripper $ATTACK/attack_rdwr_atomic
  check_atomic "attack_rdwr_atomic as the gripper, contego monitor"
  run_logged mon_mangle under monitor arm.policy gripper $ATTACK/attack_msg_flags
  check_mangling "attack_msg_flags as the gripper, contego monitor"
  stop_monitor
fi
run_logged emb_mangle under embedded arm.policy gripper $ATTACK/attack_msg_flags
check_mangling "attack_msg_flags as the gripper, contego run --policy (embedded)"
plain_expect $A 0xfe 0x65 "monitor: PRE_SCALE=101 landed, PRE_SCALE=3 and the gripper's did not"
plain_expect $A 0x00 0x21 "monitor: MODE1 = 0x21, no software reset"
plain_expect $A 0x14 0 "monitor: LED3 off, the gripper's refused transfer did not land"
plain_expect $A 0xff 0 "register 0xff: no mangled read acted as a write under the monitor or contego run"
[ "$(plain_word $A 0x1c)" = 420 ] && ok "monitor: LED5 off = 420 after the monitor stopped" ||
  bad "monitor: LED5 off = $(plain_word $A 0x1c), expected 420"

# The monitor samples the tank itself on the plain adapter (I2C_RDWR:
# [0x00], then 4 bytes): at 900 mm the buzzer's tone(1) lands; with no
# sample it would be ignored (signal-unavailable).
plain_set 0x20 0x01 0
if start_monitor tank.policy; then
  run_logged mon_tone under monitor tank.policy monitor i2cset -y 1 0x20 0x01 1
  [ $RC = 0 ] && ok "monitor: the tank task's tone(1) exits 0" || bad "monitor: tone(1) exit $RC"
  stop_monitor
fi
plain_expect 0x20 0x01 1 "monitor: the buzzer's tone(1) landed (the monitor sampled the tank at 900 mm)"

unload_plain && ok "i2c-plain-stub unloads (no descriptor left open)" || bad "rmmod i2c_plain_stub"
finish
