# contego.ko in place of i2c-dev (docs/kernel-client.md): unmodified clients
# open /dev/i2c-0 themselves -- no `contego run`, no preload, no monitor --
# and the module checks each call with the core against policies/arm.policy
# (its bus 1 is adapter 0 here: buses=1). Every decision goes through the
# module's audit ring to `contego kmod audit` and the hash-chained log; with
# no reader, or the ring full, calls fail closed. What reached the chips is
# read back at the end through the plain i2c-dev, after contego.ko is unloaded
# (which drives the safe state).
. /vm/lib.sh
KO=/lib/modules/contego.ko
if [ ! -f $KO ]; then
  # Not a failure: the host had no linux-headers for this kernel (tools/bootstrap.sh).
  echo "VM-CHECK SKIP $SCENARIO: contego.ko was not built (no kernel headers on the host)"
  exit 0
fi
A=0x40

# Known values, written through the plain i2c-dev before the swap.
stub_set $A 0xfe 0x79   # PRE_SCALE
stub_set $A 0x01 0x00   # MODE2
stub_set 0x48 0x01 0x22 # a chip the policy does not name

# The overhead bench's first row: the plain i2c-dev (ALL_LED_OFF_H = 0, which
# arm_init may write any number of times).
N=${BENCH_N:-10000}
run_logged plain i2c-write-loop 0 $A 0xfd 0 $N
plain=$(grep '^loop' "$OUT")

back_to_i2c_dev() {
  rmmod contego 2>/dev/null
  insmod /lib/modules/i2c-dev.ko && own_adapter
}

rmmod i2c_dev || { bad "cannot unload i2c-dev"; finish; }
run_logged insmod insmod $KO adapters=0 buses=1
if [ $RC != 0 ]; then
  bad "insmod contego.ko adapters=0 buses=1 (exit $RC)"
  dmesg | tail -n 5
  back_to_i2c_dev
  finish
fi
ok "contego.ko loads in place of i2c-dev"
wait_for /dev/i2c-0 10 && wait_for /dev/contego 10 && wait_for /dev/contego-audit 10 &&
  ok "/dev/i2c-0, /dev/contego and /dev/contego-audit exist" ||
  bad "no /dev/i2c-0, /dev/contego or /dev/contego-audit"
dmesg | grep -q "contego: /dev/i2c-0 checked as the policy's bus 1" &&
  ok "the kernel log names adapter 0 as the policy's bus 1" || bad "no contego line in the kernel log"
# The node is open to every user: the module, not the file mode, decides.
chmod 0666 /dev/i2c-0

run_logged nopolicy as_task i2cset -y 0 $A 0x01 0x04
[ $RC != 0 ] && ok "no policy loaded yet: i2cset is refused (exit $RC)" ||
  bad "i2cset succeeded with no policy loaded"

# arm_init: uid 1000 (task); gripper: uid 990 (contego). Root is bound to nothing.
run_logged load contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --bind gripper=contego
[ $RC = 0 ] && grep -q "loaded" "$OUT" && ok "contego kmod load: arm.policy verified and in force" ||
  bad "contego kmod load (exit $RC)"

# No audit reader yet: an allowed command fails closed (EIO) and does not land
# (the i2cget below still reads the old PRE_SCALE).
run_logged noreader as_task i2cset -y 0 $A 0xfe 101
[ $RC != 0 ] && ok "no audit reader: arm_init's allowed i2cset fails closed (exit $RC)" ||
  bad "no audit reader: i2cset succeeded"
run_logged stats0 contego kmod stats
grep -q "reader=0 .*audit_refused=1" "$OUT" && ok "module counters: reader=0, one call refused unrecorded" ||
  bad "module counters without a reader"

AUDIT_LOG=$LOGDIR/kmod-audit.jsonl
READER_PID=
start_reader() {
  contego kmod audit --policy $POLICIES/arm.policy --audit $AUDIT_LOG >>"$LOGDIR/reader.log" 2>&1 &
  READER_PID=$!
  i=0
  until contego kmod stats 2>/dev/null | grep -q "reader=1"; do
    i=$((i + 1))
    [ $i -gt 100 ] && { bad "contego kmod audit did not attach"; show "$LOGDIR/reader.log"; return 1; }
    usleep 100000
  done
}
stop_reader() {
  [ -n "$READER_PID" ] || return 0
  kill -TERM $READER_PID; wait $READER_PID; rc=$?; READER_PID=
  return $rc
}
start_reader && ok "contego kmod audit attached to the ring"

run_logged get as_task i2cget -y 0 $A 0xfe
[ "$(cat "$OUT")" = 0x79 ] && ok "arm_init: i2cget reads PRE_SCALE 0x79 through contego.ko" ||
  bad "arm_init: i2cget read '$(cat "$OUT")', the stub has 0x79"
run_logged set101 as_task i2cset -y 0 $A 0xfe 101
[ $RC = 0 ] && ok "arm_init: i2cset PRE_SCALE=101 exits 0" || bad "arm_init: i2cset PRE_SCALE=101 exit $RC"
run_logged set3 as_task i2cset -y 0 $A 0xfe 3
[ $RC = 0 ] && ok "arm_init: i2cset PRE_SCALE=3 is ignored (exit 0, policy: else ignore)" ||
  bad "arm_init: i2cset PRE_SCALE=3 exit $RC"

cat >/tmp/kmod_smbus.py <<'PY'
import smbus
bus = smbus.SMBus(0)
bus.write_byte_data(0x40, 0x01, 0x04)  # MODE2: totem pole, as Adafruit's init
print("mode2", hex(bus.read_byte_data(0x40, 0x01)))
PY
run_logged smbus as_task python3 /tmp/kmod_smbus.py
grep -q "mode2 0x4" "$OUT" && ok "arm_init: python3-smbus writes and reads MODE2" || bad "python3-smbus MODE2"

run_logged other as_task i2cset -y 0 0x48 0x01 0x55
[ $RC != 0 ] && ok "arm_init: i2cset to 0x48 (not in the policy) is refused (exit $RC)" ||
  bad "i2cset to 0x48 reported success"
run_logged root i2cset -y 0 $A 0x01 0x00
[ $RC != 0 ] && ok "root, bound to no task: i2cset is refused (exit $RC)" ||
  bad "root's unbound i2cset succeeded"

# MODE1 = AI | ALLCALL, as Adafruit's init: with auto-increment the core
# decodes the gripper's 4-byte block write as the whole LED5 group (without,
# the PCA9685 would write the bytes to one register and the core stages them).
run_logged mode1 as_task i2cset -y 0 $A 0x00 0x21
[ $RC = 0 ] && ok "arm_init: i2cset MODE1=0x21 (auto-increment) exits 0" || bad "arm_init: MODE1 exit $RC"

cat >/tmp/kmod_grip.py <<'PY'
import time
from smbus2 import SMBus
# GRIP: LED5 off must follow 420 (open), 577 (close), ...; one pulse per job (1 s).
with SMBus(0) as bus:
    bus.write_i2c_block_data(0x40, 0x1A, [0, 0, 420 & 0xFF, 420 >> 8])
    bus.write_byte_data(0x40, 0xFE, 0x03)
    print("prescale written", flush=True)
    time.sleep(1.2)
    bus.write_i2c_block_data(0x40, 0x1A, [0, 0, 577 & 0xFF, 577 >> 8])
    print("pulse sent", flush=True)
PY
echo 1 >/sys/module/contego/parameters/trace  # the gripper's decisions in the kernel log
run_logged grip su contego -s /bin/sh -c "cd /tmp && exec python3 /tmp/kmod_grip.py"
grep -q "pulse sent" "$OUT" && grep -q "prescale written" "$OUT" &&
  ok "gripper: python3-smbus2 pulse sent, PRE_SCALE reported written (ignored)" ||
  bad "gripper python3-smbus2 output"
echo 0 >/sys/module/contego/parameters/trace
dmesg | grep 'contego: task' >"$LOGDIR/grip-trace"

# The gripper's pulse, read back through contego.ko (arm_init may read the
# arm): the reader's crash below drives the safe state, LED5 off = 420.
lo=$(as_task i2cget -y 0 $A 0x1c) && hi=$(as_task i2cget -y 0 $A 0x1d)
[ $(( (hi << 8) | lo )) = 577 ] && ok "the gripper's LED5 off = 420, then 577 next job, landed" ||
  bad "LED5 off reads $lo $hi, expected 577"

# The reader dies (SIGKILL): calls fail closed until a new one attaches, and
# the new reader is handed what the old one had not acknowledged.
kill -KILL $READER_PID; wait $READER_PID 2>/dev/null; READER_PID=
run_logged crashed as_task i2cset -y 0 $A 0xfd 0
[ $RC != 0 ] && ok "audit reader killed: the next call fails closed (exit $RC)" ||
  bad "audit reader killed: i2cset succeeded"
start_reader && ok "a new audit reader attaches after the crash"
run_logged resumed as_task i2cset -y 0 $A 0xfd 0
[ $RC = 0 ] && ok "with the new reader, arm_init's allowed i2cset works again" ||
  bad "after the new reader: exit $RC"

# A bad image is refused by the module's verifier; the policy in force stays.
head -c 600 $POLICIES/arm.policy >/tmp/bad.img
run_logged badimg contego kmod load --unverified-image /tmp/bad.img
[ $RC = 1 ] && grep -q "refused" "$OUT" && ok "a bad image is refused by the module's verifier" ||
  bad "bad image: exit $RC"
run_logged after as_task i2cget -y 0 $A 0x01
[ "$(cat "$OUT")" = 0x04 ] && ok "after the refused image, arm.policy still serves arm_init" ||
  bad "after the refused image: i2cget read '$(cat "$OUT")'"
run_logged stats contego kmod stats
grep -q "loaded=1 loads=1 refused_loads=1 .*reader=1" "$OUT" &&
  ok "module counters: one load, one refused, a reader attached" ||
  bad "module counters"
# An unmodified C program (the bench client, SMBus byte-data writes) as root: refused.
run_logged loop i2c-write-loop 0 $A 0x01 0x00 5
grep -q "errors=5" "$OUT" && ok "unbound C program: all 5 writes refused" || bad "i2c-write-loop as root"

# A statically linked program (no loader: no preload could reach it) is
# checked all the same: allowed as arm_init, refused as root.
if [ -x /usr/bin/i2c-write-loop-static ]; then
  run_logged static_task as_task i2c-write-loop-static 0 $A 0xfd 0 3
  grep -q "errors=0" "$OUT" && ok "static C program as arm_init: 3 allowed writes" ||
    bad "static C program as arm_init"
  run_logged static_root i2c-write-loop-static 0 $A 0xfd 0 3
  grep -q "errors=3" "$OUT" && ok "static C program as root (unbound): 3 writes refused" ||
    bad "static C program as root"
fi

# The bench's second row: the same program and writes, as arm_init, checked in the kernel.
run_logged kbench as_task i2c-write-loop 0 $A 0xfd 0 $N
kmod=$(grep '^loop' "$OUT")
field() { echo "$1" | sed -n "s/.*$2=\([0-9.]*\).*/\1/p"; }
if echo "$plain" | grep -q 'errors=0' && echo "$kmod" | grep -q 'errors=0'; then
  ok "bench: $N writes on the plain i2c-dev and on contego.ko, no errors"
  echo "  bench: $N writes per row, ${ACCEL:-unknown accelerator} ($(nproc) vCPUs); under TCG only the difference means something, roughly."
  printf '  %-28s %10s %10s %10s\n' row median_us p99_us worst_us
  for row in plain kmod; do
    eval line=\$$row
    printf '  %-28s %10s %10s %10s\n' "$([ $row = plain ] && echo 'plain i2c-dev' || echo 'contego.ko (arm_init)')" \
      "$(field "$line" median_us)" "$(field "$line" p99_us)" "$(field "$line" max_us)"
  done
  awk -v m="$(field "$kmod" median_us)" -v pm="$(field "$plain" median_us)" \
    -v p="$(field "$kmod" p99_us)" -v pp="$(field "$plain" p99_us)" \
    -v w="$(field "$kmod" max_us)" -v pw="$(field "$plain" max_us)" \
    'BEGIN { printf "  added per command: median %.1f us, p99 %.1f us, worst %.1f us; median ratio %.2fx\n", m - pm, p - pp, w - pw, m / pm }'
else
  bad "bench rows did not complete: plain '$plain', contego.ko '$kmod'"
fi

# LED5 to 577 again, so that the unload's safe state shows on the chip. The
# GRIP sequence goes on from the last command checked (577): 420, then 577.
run_logged led420 as_task i2cset -y 0 $A 0x1a 0 0 0xa4 0x01 i
run_logged led577 as_task i2cset -y 0 $A 0x1a 0 0 0x41 0x02 i
lo=$(as_task i2cget -y 0 $A 0x1c) && hi=$(as_task i2cget -y 0 $A 0x1d)
[ $(( (hi << 8) | lo )) = 577 ] && ok "arm_init: LED5 off = 577 before the unload" ||
  bad "LED5 off reads $lo $hi before the unload, expected 577"

# The log: one chain, every decision and event of the module in it.
stop_reader && ok "contego kmod audit stops on SIGTERM (exit 0)" || bad "contego kmod audit exit $rc"
show "$LOGDIR/reader.log"
run_logged verify contego audit $AUDIT_LOG
[ $RC = 0 ] && ok "contego audit verifies the module's log" || bad "contego audit exit $RC"
for what in '"kind":"audit-gap"' '"kind":"policy-load-refused"' \
    '"decision":"ignore"' '"decision":"reject"' '"task_name":"gripper"' '"rule_name":"PRESCALE"'; do
  grep -q "$what" $AUDIT_LOG && ok "the module's log has $what" || bad "the module's log lacks $what"
done
kbench_lines=$(grep -c '"task_name":"arm_init"' $AUDIT_LOG)
[ "$kbench_lines" -ge "$N" ] && ok "every one of the bench's $N commands has its record ($kbench_lines arm_init lines)" ||
  bad "only $kbench_lines arm_init records for $N bench commands"

# What reached the chips, through the plain i2c-dev.
rmmod contego && ok "contego.ko unloads" || bad "rmmod contego"
dmesg | grep -q "contego: unloading: 1 devices driven to their safe state" &&
  ok "the unload drove the arm's safe state" || bad "no safe state at unload in the kernel log"
back_to_i2c_dev
expect_reg $A 0xfe 101 "PRE_SCALE=101 landed; PRE_SCALE=3 (arm_init, gripper) did not"
expect_reg $A 0x01 0x04 "MODE2=0x04 landed; root's MODE2=0 did not"
expect_reg 0x48 0x01 0x22 "nothing reached chip 0x48"
expect_reg $A 0x00 0x21 "MODE1=0x21 landed"
expect_word $A 0x1c 420 "after the unload: the safe state, LED5 off = 420"

# A full ring fails closed too: a small ring (audit_records=64) and a reader
# that stops reading (SIGSTOP). Reloaded, the module starts with no policy.
rmmod i2c_dev
run_logged insmod2 insmod $KO adapters=0 buses=1 audit_records=64
wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
start_reader
run_logged load2 contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --bind gripper=contego
kill -STOP $READER_PID
# A flood of refused calls (root is bound to no task) cannot take the room
# the records of actions need: three quarters of the ring at most.
run_logged flood i2c-write-loop 0 $A 0xfd 0 100
run_logged after_flood as_task i2cset -y 0 $A 0xfd 0
grep -q "errors=100" "$LOGDIR/flood.out" && [ $RC = 0 ] &&
  ok "100 refused writes from an unbound process leave room: arm_init's write still acts" ||
  bad "after a flood of refused writes: arm_init's write exit $RC"
run_logged full as_task i2c-write-loop 0 $A 0xfd 0 200
errors=$(sed -n 's/.*errors=\([0-9]*\).*/\1/p' "$OUT")
[ -n "$errors" ] && [ "$errors" -gt 100 ] && [ "$errors" -lt 200 ] &&
  ok "reader stopped, ring of 64: the first writes pass, the other $errors of 200 fail closed" ||
  bad "ring full: errors=$errors of 200"
kill -CONT $READER_PID
run_logged after_full as_task i2cset -y 0 $A 0xfd 0
[ $RC = 0 ] && ok "the reader drains the ring: calls work again" || bad "after the drain: exit $RC"

# Identity from kernel facts, as the policy declares it: arm_init is
# i2cset (exe) in the cgroup /robot or below; the gripper stays bound to
# uid 990 by --bind. The module checks the facts on every call.
mkdir -p /sys/fs/cgroup && { mountpoint -q /sys/fs/cgroup || mount -t cgroup2 none /sys/fs/cgroup; }
mkdir -p /sys/fs/cgroup/robot/arm
awk '{ print } /^task arm_init \{/ { print "  exe \"/usr/sbin/i2cset\"; cgroup \"/robot\"" }' \
  $POLICIES/arm.policy >/tmp/arm-bound.policy
run_logged load3 contego kmod load --policy /tmp/arm-bound.policy --bind gripper=contego
[ $RC = 0 ] && ok "kmod load: arm_init bound by exe and cgroup" || bad "kmod load of the bound policy (exit $RC)"
in_cgroup() {  # in_cgroup CGROUP COMMAND...: runs COMMAND as the task user inside CGROUP
  cg=$1; shift
  sh -c "echo \$\$ >/sys/fs/cgroup$cg/cgroup.procs && exec su task -s /bin/sh -c 'cd /tmp && exec $*'"
}
run_logged id_ok in_cgroup /robot/arm /usr/sbin/i2cset -y 0 $A 0xfd 0
[ $RC = 0 ] && ok "i2cset in /robot/arm acts as arm_init (exe and cgroup met)" || bad "i2cset in /robot/arm: exit $RC"
run_logged id_cgroup as_task i2cset -y 0 $A 0xfd 0
[ $RC != 0 ] && ok "the same i2cset outside /robot is no task: refused (exit $RC)" ||
  bad "i2cset outside the bound cgroup succeeded"
run_logged id_exe in_cgroup /robot python3 /tmp/kmod_smbus.py
[ $RC != 0 ] && ok "python3 in /robot (another exe) is no task: refused (exit $RC)" ||
  bad "python3 with the wrong exe succeeded"

stop_reader
run_logged verify2 contego audit $AUDIT_LOG
[ $RC = 0 ] && grep -q '"kind":"audit-gap"' $AUDIT_LOG &&
  ok "the log still verifies, the lost records are an audit-gap record" || bad "log after the full ring"
back_to_i2c_dev
[ $FAILS = 0 ] || { echo "  the gripper's decisions (kernel log, trace=1):"; show "$LOGDIR/grip-trace"; }
finish
