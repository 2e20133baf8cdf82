# contego.ko in place of i2c-dev (docs/kernel-client.md): unmodified clients
# open /dev/i2c-0 themselves -- no `contego run`, no preload, no monitor --
# and the module checks each call with the core against policies/arm.policy
# (its bus 1 is adapter 0 here: buses=1). Every decision goes through the
# module's audit ring to `contego kmod audit` and the hash-chained log; with
# no reader, or the ring full, calls fail closed. A process that acted as a
# task is a session: its exit (SIGKILL too) drives the task's actuators to
# their safe state; a script's i2cset runs are one session. The module
# samples sensors itself (policies/tank.policy: the buzzer follows the tank's
# level set on the stub). What reached the chips is read back through the
# plain i2c-dev, after contego.ko is unloaded (which drives the safe state).
. /vm/lib.sh
. /vm/inc/kmod.sh
kmod_built_or_skip
A=0x40

# Known values, written through the plain i2c-dev before the swap.
stub_set $A 0x00 0x11   # MODE1: asleep, the power-on value (PRE_SCALE takes writes only so)
stub_set $A 0xfe 0x79   # PRE_SCALE
stub_set $A 0x01 0x00   # MODE2
stub_set 0x48 0x01 0x22 # a chip the policy does not name

# The overhead bench's first row: the plain i2c-dev (ALL_LED_OFF_H = 0, which
# arm_init may write any number of times).
N=${BENCH_N:-10000}
run_logged plain i2c-write-loop 0 $A 0xfd 0 $N
plain=$(grep '^loop' "$OUT")

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
# The bench below sends 10,000 writes in one of arm_init's 10 s jobs: the
# over-budget hold (4 x its 8 actuations per job by default) is off here; the
# last part of the scenario tests it.
run_logged load contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --bind gripper=contego \
  --budget-factor 0
[ $RC = 0 ] && grep -q "loaded" "$OUT" && ok "contego kmod load: arm.policy verified and in force" ||
  bad "contego kmod load (exit $RC)"
# The PCA9685's shadow is read back from the chip at the load (as the
# monitor does at start), not assumed at its power-on values.
seeded=$(dmesg | grep -o "contego: device 0 (bus 1 0x40): shadow read back from the device ([0-9]* registers)" | tail -n1)
[ -n "$seeded" ] && ok "the load read the PCA9685's registers back into its shadow: ${seeded#contego: }" ||
  bad "no shadow read back at the load: $(dmesg | grep 'contego: device' | tail -n 2)"

# No audit reader yet: an allowed command fails closed (EIO) and does not land
# (the i2cget below still reads the old PRE_SCALE).
run_logged noreader as_task i2cset -y 0 $A 0xfe 101
[ $RC != 0 ] && ok "no audit reader: arm_init's allowed i2cset fails closed (exit $RC)" ||
  bad "no audit reader: i2cset succeeded"
run_logged stats0 contego kmod stats
grep -q "reader=0 .*audit_refused=1" "$OUT" && ok "module counters: reader=0, one call refused unrecorded" ||
  bad "module counters without a reader"

AUDIT_LOG=$LOGDIR/kmod-audit.jsonl
start_reader && ok "contego kmod audit attached to the ring"

run_logged get as_task i2cget -y 0 $A 0xfe
[ "$(cat "$OUT")" = 0x79 ] && ok "arm_init: i2cget reads PRE_SCALE 0x79 through contego.ko" ||
  bad "arm_init: i2cget read '$(cat "$OUT")', the stub has 0x79"
run_logged set101 as_task i2cset -y 0 $A 0xfe 101
[ $RC = 0 ] && ok "arm_init: i2cset PRE_SCALE=101 exits 0" || bad "arm_init: i2cset PRE_SCALE=101 exit $RC"
run_logged set3 as_task i2cset -y 0 $A 0xfe 3
[ $RC = 0 ] && ok "arm_init: i2cset PRE_SCALE=3 is ignored (exit 0, policy: else ignore)" ||
  bad "arm_init: i2cset PRE_SCALE=3 exit $RC"

# Adafruit_PureIO's read_byte_data: one I2C_RDWR of a register pointer and a
# one-byte read. i2c-stub speaks SMBus only: contego.ko sends it as SMBus
# read byte data, as the monitor does, instead of refusing it.
cat >/tmp/kmod_rdwr.py <<'PY'
from smbus2 import SMBus, i2c_msg
with SMBus(0) as bus:
    w, r = i2c_msg.write(0x40, [0xFE]), i2c_msg.read(0x40, 1)
    bus.i2c_rdwr(w, r)
    print("prescale", list(r)[0])
PY
run_logged rdwr as_task python3 /tmp/kmod_rdwr.py
grep -q "prescale 101" "$OUT" &&
  ok "arm_init: a combined write-then-read on the SMBus-only adapter reads PRE_SCALE 101 through contego.ko" ||
  bad "arm_init: the combined write-then-read failed on the SMBus-only adapter (exit $RC)"

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
    d = bus.read_i2c_block_data(0x40, 0x1C, 2)  # LED5 off, read back through contego.ko
    print("led5", d[0] | d[1] << 8, flush=True)
PY
echo 1 >/sys/module/contego/parameters/trace  # the gripper's decisions in the kernel log
run_logged grip su contego -s /bin/sh -c "cd /tmp && exec python3 /tmp/kmod_grip.py"
grep -q "pulse sent" "$OUT" && grep -q "prescale written" "$OUT" &&
  ok "gripper: python3-smbus2 pulse sent, PRE_SCALE reported written (ignored)" ||
  bad "gripper python3-smbus2 output"
echo 0 >/sys/module/contego/parameters/trace
dmesg | grep 'contego: task' >"$LOGDIR/grip-trace"

# The gripper's pulse, read back by the gripper itself through contego.ko;
# its exit ends its session: the gripper's actuators (the arm) go to their
# safe state, LED5 off = 420 (read by arm_init, which may read the arm; a
# read opens no session).
grep -q "led5 577" "$OUT" && ok "the gripper's LED5 off = 420, then 577 next job, landed" ||
  bad "the gripper read LED5 back as '$(sed -n 's/^led5 //p' "$OUT")', expected 577"
led5_becomes 420 && ok "the gripper exited: its session's end drove LED5 off = 420 (the safe state)" ||
  bad "after the gripper exited LED5 off reads $(led5), expected the safe state 420"

# A controller bound to the gripper holds LED5 at 577 and is killed
# (SIGKILL): the end of its process ends its session, and the module drives
# the gripper's actuators to their safe state from its work queue.
# The gripper's jobs run on its period grid across its processes (as in the
# monitor): the pulse of kmod_grip.py spent the current job's one LED write,
# so the controller waits for the next job before its first pulse (on a fast
# host it starts within that job and its 420 would be ignored, rate-exceeded).
cat >/tmp/kmod_ctl.py <<'PY'
import time
from smbus2 import SMBus
bus = SMBus(0)
time.sleep(1.2)
bus.write_i2c_block_data(0x40, 0x1A, [0, 0, 420 & 0xFF, 420 >> 8])
time.sleep(1.2)
bus.write_i2c_block_data(0x40, 0x1A, [0, 0, 577 & 0xFF, 577 >> 8])
d = bus.read_i2c_block_data(0x40, 0x1C, 2)
print("holding", d[0] | d[1] << 8, flush=True)
time.sleep(600)
PY
rm -f /tmp/ctl.pid
su contego -s /bin/sh -c 'cd /tmp && echo $$ >/tmp/ctl.pid && exec python3 /tmp/kmod_ctl.py' \
  >"$LOGDIR/ctl.out" 2>&1 &
i=0
until grep -q holding "$LOGDIR/ctl.out" 2>/dev/null; do
  i=$((i + 1)); [ $i -gt 150 ] && break
  usleep 100000
done
show "$LOGDIR/ctl.out"
CTL=$(cat /tmp/ctl.pid 2>/dev/null)
grep -q "holding 577" "$LOGDIR/ctl.out" && [ "$(led5)" = 577 ] &&
  ok "a gripper controller (pid $CTL) holds LED5 off = 577" || bad "the controller does not hold LED5 at 577"
kill -KILL "$CTL"
led5_becomes 420 && ok "controller killed (SIGKILL): its session's end drove LED5 off = 420" ||
  bad "after SIGKILL of the controller LED5 off reads $(led5), expected the safe state 420"
dmesg | grep -q "contego: task 1: session of pid $CTL ended (wait status 0x9)" &&
  ok "the kernel log names the killed controller's session end" || bad "no session end of pid $CTL in the kernel log"

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

# A shell script's i2cset runs are one session: each i2cset exits 0 and is
# not its process group's leader (the script is), so the arm is not reset
# between them; the script's end ends the session. The script gets a process
# group of its own as an interactive shell or systemd would give it: here
# every process is in the group of the guest's init (no leader: each
# process's exit would end its session), hence setsid. The GRIP sequence
# goes on from the last command checked (577): 420, then 577.
cat >/tmp/kmod_led.sh <<'SH'
/usr/sbin/i2cset -y 0 0x40 0x1a 0 0 0xa4 0x01 i
/usr/sbin/i2cset -y 0 0x40 0x1a 0 0 0x41 0x02 i
sleep 1
lo=$(/usr/sbin/i2cget -y 0 0x40 0x1c) && hi=$(/usr/sbin/i2cget -y 0 0x40 0x1d)
echo "led5 $(( (hi << 8) | lo ))"
SH
run_logged ledscript as_task setsid sh /tmp/kmod_led.sh
grep -q "led5 577" "$OUT" &&
  ok "a script's i2cset runs are one session: LED5 off = 577 a second after the last one exited" ||
  bad "script: LED5 off read '$(sed -n 's/^led5 //p' "$OUT")' inside the script, expected 577"
led5_becomes 420 && ok "the script's end ended its session: LED5 off = 420" ||
  bad "after the script LED5 off reads $(led5), expected the safe state 420"

# Adafruit's current driver with auto-increment off: each 5-byte pulse
# lands whole in LED5_ON_L, held (the group never completes), and the second
# says the first never reached the chip: a staged-incomplete record, as
# under the monitor (the core both clients share). Auto-increment back on.
run_logged ai_off as_task i2cset -y 0 $A 0x00 0x01
cat >/tmp/kmod_held.py <<'PY'
from smbus2 import SMBus
with SMBus(0) as bus:
    for off in (420, 577):
        bus.write_i2c_block_data(0x40, 0x1A, [0, 0, off & 0xFF, off >> 8])
print("held", flush=True)
PY
run_logged held as_task python3 /tmp/kmod_held.py
grep -q "^held" "$OUT" && [ "$(led5)" = 420 ] &&
  ok "two whole-pulse writes with auto-increment off: told success, LED5 off still 420" ||
  bad "held pulses: output '$(cat "$OUT")', LED5 off $(led5)"
run_logged ai_on as_task i2cset -y 0 $A 0x00 0x21
[ $RC = 0 ] && ok "arm_init: MODE1=0x21 again" || bad "arm_init: MODE1 back exit $RC"

# LED5 to 577 again, held by a live session (a script still running), so
# that the unload's safe state shows on the chip and the unload meets a
# session it must take off its wait queue.
start_led5_holder
[ "$(led5)" = 577 ] && ok "arm_init: LED5 off = 577 before the unload, its session live (pid $HOLDER)" ||
  bad "LED5 off reads $(led5) before the unload, expected 577"

# The log: one chain, every decision and event of the module in it.
stop_reader && ok "contego kmod audit stops on SIGTERM (exit 0)" || bad "contego kmod audit exit $rc"
show "$LOGDIR/reader.log"
run_logged verify contego audit $AUDIT_LOG
[ $RC = 0 ] && ok "contego audit verifies the module's log" || bad "contego audit exit $RC"
for what in '"kind":"audit-gap"' '"kind":"policy-load-refused"' \
    '"decision":"ignore"' '"decision":"reject"' '"task_name":"gripper"' '"rule_name":"PRESCALE"' '"mono_us":' \
    '"command_name":"led","decision":"ignore".*"reason_name":"staged-incomplete"' \
    "task 1 (gripper) exited: pid $CTL uid 990 killed by signal 9; device 0 (arm)" \
    "task 0 (arm_init) exited: pid [0-9]* uid 1000 exited with status 0, then its process group's leader exited"; do
  grep -q "$what" $AUDIT_LOG && ok "the module's log has $what" || bad "the module's log lacks $what"
done
kbench_lines=$(grep -c '"task_name":"arm_init"' $AUDIT_LOG)
[ "$kbench_lines" -ge "$N" ] && ok "every one of the bench's $N commands has its record ($kbench_lines arm_init lines)" ||
  bad "only $kbench_lines arm_init records for $N bench commands"

# What reached the chips, through the plain i2c-dev.
klog_mark unload
rmmod contego && ok "contego.ko unloads" || bad "rmmod contego"
dmesg | grep -q "contego: unloading: 1 devices driven to their safe state" &&
  ok "the unload drove the arm's safe state" || bad "no safe state at unload in the kernel log"
# The session the unload took off its wait queue: its process ends after the module.
[ -n "$HOLDER" ] && kill -KILL "$HOLDER"
sleep 1
klog_since unload | grep -E "BUG|Oops|WARNING|general protection" >/tmp/klog.bad
[ -s /tmp/klog.bad ] && bad "kernel log after the unload and the held session's end: $(head -n 1 /tmp/klog.bad)" ||
  ok "a session live at the unload ends after it without a kernel warning"
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
run_logged load2 contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --bind gripper=contego \
  --budget-factor 0
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
# It also answers arm_init's ignored calls with EIO (`ignore_errno`).
awk '{ print } /^task arm_init \{/ { print "  exe \"/usr/sbin/i2cset\"; cgroup \"/robot\"; ignore_errno EIO" }' \
  $POLICIES/arm.policy >/tmp/arm-bound.policy
run_logged load3 contego kmod load --policy /tmp/arm-bound.policy --bind gripper=contego
[ $RC = 0 ] && ok "kmod load: arm_init bound by exe and cgroup" || bad "kmod load of the bound policy (exit $RC)"
in_cgroup() {  # in_cgroup CGROUP COMMAND...: runs COMMAND as the task user inside CGROUP
  cg=$1; shift
  sh -c "echo \$\$ >/sys/fs/cgroup$cg/cgroup.procs && exec su task -s /bin/sh -c 'cd /tmp && exec $*'"
}
run_logged id_ok in_cgroup /robot/arm /usr/sbin/i2cset -y 0 $A 0xfd 0
[ $RC = 0 ] && ok "i2cset in /robot/arm acts as arm_init (exe and cgroup met)" || bad "i2cset in /robot/arm: exit $RC"
run_logged id_errno in_cgroup /robot/arm /usr/sbin/i2cset -y 0 $A 0xfe 3
[ $RC != 0 ] && ok "arm_init's ignored PRE_SCALE=3 fails (exit $RC): the task's ignore_errno EIO" ||
  bad "arm_init's ignored PRE_SCALE=3 exited 0 under ignore_errno"
run_logged id_cgroup as_task i2cset -y 0 $A 0xfd 0
[ $RC != 0 ] && ok "the same i2cset outside /robot is no task: refused (exit $RC)" ||
  bad "i2cset outside the bound cgroup succeeded"
run_logged id_exe in_cgroup /robot python3 /tmp/kmod_smbus.py
[ $RC != 0 ] && ok "python3 in /robot (another exe) is no task: refused (exit $RC)" ||
  bad "python3 with the wrong exe succeeded"

# The exec case: identity is the caller's at each call, not the opener's. A
# process that acts as arm_init (python3, bound by exe in this policy) keeps
# its bus descriptor across an execve into a shell: the shell's write on the
# very same open file is refused, and so would any other binary's be.
awk '{ print } /^task arm_init \{/ { print "  exe \"/usr/bin/python3\"" }' \
  $POLICIES/arm.policy >/tmp/arm-py.policy
run_logged load4 contego kmod load --policy /tmp/arm-py.policy --bind gripper=contego
cat >/tmp/kmod_exec.py <<'PY'
import fcntl, os, sys
fd = os.open("/dev/i2c-0", os.O_RDWR)
os.set_inheritable(fd, True)           # kept across the exec
fcntl.ioctl(fd, 0x0703, 0x40)          # I2C_SLAVE
os.write(fd, bytes([0xfd, 0x00]))      # ALL_LED_OFF_H = 0: arm_init may
print("python3 wrote", flush=True)
os.execv("/bin/sh", ["sh", "-c", "printf '\\375\\020' >&%d && echo shell wrote" % fd])
PY
run_logged id_exec as_task python3 /tmp/kmod_exec.py
grep -q "python3 wrote" "$OUT" && ! grep -q "shell wrote" "$OUT" &&
  ok "exec: python3 acts as arm_init; after its execve the shell's write on the same descriptor is refused" ||
  bad "exec: the descriptor kept acting after the exec into another binary"

stop_reader
run_logged verify2 contego audit $AUDIT_LOG
[ $RC = 0 ] && grep -q '"kind":"audit-gap"' $AUDIT_LOG &&
  ok "the log still verifies, the lost records are an audit-gap record" || bad "log after the full ring"
back_to_i2c_dev

# Sensors: policies/tank.policy lets the buzzer sound (tone 1) only while the
# tank's level is above 800 mm or its temperature out of 5..40 degC (INV_W);
# the module samples the tank itself on the bus ([0x00], then 4 bytes:
# big-endian level and temperature; an I2C block read on i2c-stub). Each
# round sets the level on the stub through the plain i2c-dev, loads
# contego.ko, and for each policy given loads it and sends the monitor
# task's tone(1); the buzzer is read back after the unload. Their records go
# to a log of their own (tank.policy's names).
AUDIT_LOG=$LOGDIR/kmod-tank.jsonl
tank_round() {  # tank_round LABEL LEVEL POLICY...
  round=$1 level=$2; shift 2  # not `label`: run_logged sets that
  stub_set 0x48 0x00 $((level >> 8)); stub_set 0x48 0x01 $((level & 0xff))
  stub_set 0x48 0x02 0; stub_set 0x48 0x03 200  # 20.0 degC
  stub_set 0x20 0x01 0
  rmmod i2c_dev
  run_logged ${round}_insmod insmod $KO adapters=0 buses=1
  wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
  # Every policy of the round: each record is named from the image in force.
  start_reader "$(echo "$@" | sed 's/ / --policy /g')"
  n=0
  for policy in "$@"; do
    n=$((n + 1))
    if [ -n "$KMOD_LOAD_OPTS" ]; then  # the load without them first
      run_logged ${round}_strict$n contego kmod load --policy $policy --bind monitor=task
      eval STRICT_RC$n=$RC
    fi
    run_logged ${round}_load$n contego kmod load --policy $policy --bind monitor=task $KMOD_LOAD_OPTS
    run_logged ${round}_tone$n as_task i2cset -y 0 0x20 0x01 1
    eval TONE_RC$n=$RC
    run_logged ${round}_stats$n contego kmod stats
  done
  stop_reader
  back_to_i2c_dev
}
tank_round tank500 500 $POLICIES/tank.policy
[ $TONE_RC1 = 0 ] && grep -q "samples=[1-9].* sample_errors=0" "$LOGDIR/tank500_stats1.out" &&
  ok "level 500 mm: the module sampled the tank; tone(1) exits 0 (ignored, INV_W)" ||
  bad "level 500: tone(1) exit $TONE_RC1, $(cat "$LOGDIR/tank500_stats1.out")"
expect_reg 0x20 0x01 0 "level 500 mm (normal): the buzzer's tone(1) did not land"
# Level 900, first with the tank moved to an address where nothing answers:
# the load is refused (its first sample cannot be read, as the monitor
# refuses to start); loaded with --allow-degraded, its sample fails, its
# signals are unavailable, and tone(1) is ignored (fail closed, recorded as
# signal-unavailable); then with tank.policy itself: tone(1) lands.
sed 's/^device tank : regmap at i2c-1 0x48/device tank : regmap at i2c-1 0x49/' \
  $POLICIES/tank.policy >/tmp/tank-missing.policy
KMOD_LOAD_OPTS=--allow-degraded tank_round tank900 900 /tmp/tank-missing.policy $POLICIES/tank.policy
[ "$STRICT_RC1" = 1 ] && [ "$STRICT_RC2" = 0 ] &&
  grep -q "load refused: the first sample of tank (i2c-1 0x49) could not be read" "$LOGDIR/tank900_strict1.out" &&
  grep -q "allow-degraded: loaded although the first sample of tank (i2c-1 0x49) could not be read" "$LOGDIR/tank900_load1.out" &&
  ok "a load whose sensor cannot be read is refused ($(cat "$LOGDIR/tank900_strict1.out")); --allow-degraded loads it, and says so" ||
  bad "the load of an unreadable sensor: exit $STRICT_RC1 ($(cat "$LOGDIR/tank900_strict1.out")), tank.policy's exit $STRICT_RC2"
grep -q "sample_errors=[1-9]" "$LOGDIR/tank900_stats1.out" &&
  grep -q '"reason_name":"signal-unavailable".*"rule_name":"INV_W"' $AUDIT_LOG &&
  ok "a tank that does not answer: the failed sample is counted, tone(1) ignored as signal-unavailable" ||
  bad "the unreadable tank: $(cat "$LOGDIR/tank900_stats1.out")"
grep -q '"detail":"contego.ko: image of [0-9]* bytes verified and in force;.*tank-missing.policy (SHA-256 [0-9a-f]*), whose names' $AUDIT_LOG &&
  grep -q '"detail":"contego.ko: image of [0-9]* bytes verified and in force;.*/tank.policy (SHA-256 [0-9a-f]*), whose names' $AUDIT_LOG &&
  ok "the reader's names follow each policy-load record (tank-missing.policy, then tank.policy)" ||
  bad "the policy-load lines do not say whose names follow: $(grep policy-load $AUDIT_LOG | tail -n 2)"
[ $TONE_RC2 = 0 ] && ok "level 900 mm: tone(1) exits 0" || bad "level 900: tone(1) exit $TONE_RC2"
expect_reg 0x20 0x01 1 "level 900 mm (high): the buzzer's tone(1) landed"
run_logged verify3 contego audit $AUDIT_LOG
[ $RC = 0 ] && grep -q '"rule_name":"INV_W"' $AUDIT_LOG &&
  ok "the log verifies and has the INV_W decisions" || bad "the log after the tank rounds"

# The policy's `sessions` and the over-budget hold, as the monitor enforces
# them (docs/kernel-client.md "Sessions", "Budget"). A copy of arm.policy
# whose arm_init has a 500 ms period and one actuation per job: with
# --budget-factor 4 (the default) its budget is 4 writes per job; its
# `sessions` is the default, 1.
AUDIT_LOG=$LOGDIR/kmod-limits.jsonl
LIMITS=/tmp/arm-limits.policy
sed -e 's/^  period 10s; deadline 10s; wcet 50ms; priority 1$/  period 500ms; deadline 500ms; wcet 50ms; priority 1/' \
  -e 's/^  actuations 8$/  actuations 1/' $POLICIES/arm.policy >$LIMITS
rmmod i2c_dev
run_logged limits_insmod insmod $KO adapters=0 buses=1
wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
start_reader $LIMITS
limits_load() {
  run_logged limits_load$1 contego kmod load --policy $LIMITS --bind arm_init=task --bind gripper=contego
}
limits_load 1
[ $RC = 0 ] && grep -q "budget factor 4" "$OUT" && ok "kmod load: arm_init with a 500 ms period, budget factor 4 (the default)" ||
  bad "kmod load of $LIMITS (exit $RC)"

# sessions 1: a script of arm_init acted (its i2cset's session went to the
# script, its process group's leader) and lives on; a second arm_init
# process outside its group is refused (EACCES, as the monitor refuses a
# second hello) and audited, while the script lives.
rm -f /tmp/holder2.pid
as_task setsid sh -c '/usr/sbin/i2cset -y 0 0x40 0xfd 0 && echo $$ >/tmp/holder2.pid && exec sleep 600' \
  >"$LOGDIR/holder2.out" 2>&1 &
wait_for /tmp/holder2.pid 10
HOLDER2=$(cat /tmp/holder2.pid 2>/dev/null)
cat >/tmp/kmod_second.py <<'PY'
import errno, smbus
bus = smbus.SMBus(0)
try:
    bus.write_byte_data(0x40, 0xfd, 0)
    print("written", flush=True)
except OSError as e:
    print("refused", errno.errorcode[e.errno], flush=True)
print("read", hex(bus.read_byte_data(0x40, 0xfe)), flush=True)
PY
run_logged second as_task python3 /tmp/kmod_second.py
grep -q "^refused EACCES" "$OUT" &&
  ok "sessions 1: a second arm_init process is refused (EACCES) while a script of arm_init (pid $HOLDER2) has its session" ||
  bad "sessions 1: the second arm_init process: $(head -n 1 "$OUT")"
grep -q "^read 0x" "$OUT" && ok "the refused process may still read (a read opens no session)" ||
  bad "the refused process's read: $(sed -n 2p "$OUT")"
run_logged limits_stats1 contego kmod stats
grep -q "sessions=1 .*sessions_limited=1 " "$OUT" && ok "module counters: one live session, one call refused for sessions" ||
  bad "module counters after the refused session"
[ -n "$HOLDER2" ] && kill -KILL "$HOLDER2"
wait_sessions_closed
run_logged second_after as_task python3 /tmp/kmod_second.py
grep -q "^written" "$OUT" && ok "the script killed, its session ended: the next arm_init process acts" ||
  bad "after the script's end: $(head -n 1 "$OUT")"

# The hold: 20 writes back to back from one process, right after a load
# (the job grid starts at the first): 4 per job, the 5th, 9th, 13th and
# 17th wait for the next release, so the 20 take 4 periods (2 s; unheld
# they take milliseconds). Bounds are loose: TCG, a loaded host.
limits_load 2
run_logged burst as_task i2c-write-loop 0 $A 0xfd 0 20
total_ms=$(sed -n 's/.*mean_us=\([0-9.]*\).*/\1/p' "$OUT" | awk '{ printf "%d", $1 * 20 / 1000 }')
grep -q "errors=0" "$OUT" && [ -n "$total_ms" ] && [ "$total_ms" -ge 1950 ] && [ "$total_ms" -le 3000 ] &&
  ok "over-budget hold: 5 bursts of 4 writes (budget 4 x 1 per 500 ms job) took $total_ms ms, about 4 periods" ||
  bad "over-budget hold: 20 writes took '$total_ms' ms (expected 2000 to 3000), $(cat "$OUT")"
run_logged limits_stats2 contego kmod stats
grep -q " holds=4 " "$OUT" && ok "module counters: 4 holds" || bad "module counters after the burst: $(cat "$OUT")"

# A signal does not cut the hold short into an unchecked write: a timer
# every 50 ms interrupts the held 5th write (EINTR: Python's handlers have
# no SA_RESTART); retried, it is held again until the release.
limits_load 3
cat >/tmp/kmod_alarm.py <<'PY'
import signal, smbus, time
signal.signal(signal.SIGALRM, lambda s, f: None)
bus = smbus.SMBus(0)
interrupted = 0
t0 = time.monotonic()
signal.setitimer(signal.ITIMER_REAL, 0.05, 0.05)
for i in range(8):
    while True:
        try:
            bus.write_byte_data(0x40, 0xfd, 0)
            break
        except InterruptedError:
            interrupted += 1
signal.setitimer(signal.ITIMER_REAL, 0)
print("elapsed_ms %d interrupted %d" % ((time.monotonic() - t0) * 1000, interrupted), flush=True)
PY
run_logged alarm as_task python3 /tmp/kmod_alarm.py
alarm_ms=$(sed -n 's/^elapsed_ms \([0-9]*\) .*/\1/p' "$OUT")
[ $RC = 0 ] && [ -n "$alarm_ms" ] && [ "$alarm_ms" -ge 480 ] && [ "$alarm_ms" -le 1500 ] &&
  ok "over-budget hold under a 50 ms timer: 8 writes still took one period ($(cat "$OUT"))" ||
  bad "over-budget hold under signals (exit $RC): $(cat "$OUT")"

# Calls that did not act have their own budget, 4 x max(1, 8) = 32 per job
# (contego/job_budget.h, as the monitor's): 40 writes of PRE_SCALE = 3,
# which the policy ignores, answer at once until the 33rd, whose sender
# waits after its answer for the next release; the task's acting budget is
# untouched, so its next acting write is not held.
limits_load 4
run_logged flood as_task i2c-write-loop 0 $A 0xfe 3 40
flood_ms=$(sed -n 's/.*mean_us=\([0-9.]*\).*/\1/p' "$OUT" | awk '{ printf "%d", $1 * 40 / 1000 }')
run_logged after_flood as_task i2c-write-loop 0 $A 0xfd 0 1
acting_ms=$(sed -n 's/.*mean_us=\([0-9.]*\).*/\1/p' "$OUT" | awk '{ printf "%d", $1 / 1000 }')
[ -n "$flood_ms" ] && [ "$flood_ms" -ge 400 ] && [ "$flood_ms" -le 1500 ] && [ -n "$acting_ms" ] && [ "$acting_ms" -lt 200 ] &&
  ok "dropped-call budget: 40 ignored writes took $flood_ms ms (the 33rd waited for the next release), the next acting write $acting_ms ms" ||
  bad "dropped-call budget: 40 ignored writes took '$flood_ms' ms (expected 400 to 1500), the acting write '$acting_ms' ms"

# Another contego's load request (the size before the per-task limits, 48
# bytes; version 3's 344, before the degraded flag; or this size with version
# 3) is refused with EPROTO, not misread; a version mismatch gets the
# module's version back. A version-4 request with an unknown flag, or its pad
# not zero, is refused (EINVAL) before anything is loaded; the same request
# with both zero loads.
contego check $LIMITS --emit /tmp/limits.img >/dev/null 2>&1
cat >/tmp/kmod_requests.py <<'PY'
import ctypes, errno, fcntl, os, struct
fd = os.open("/dev/contego", os.O_RDWR)
img = open("/tmp/limits.img", "rb").read()
image = ctypes.create_string_buffer(img, len(img))
def load(b):  # CONTEGO_KMOD_LOAD of len(b) bytes: "ok" or the errno's name
    try:
        fcntl.ioctl(fd, (3 << 30) | (len(b) << 16) | (0xC7 << 8) | 1, b)
        return "ok"
    except OSError as e:
        return errno.errorcode[e.errno]
def other(size, version):
    b = bytearray(size)
    b[0:4] = version.to_bytes(4, "little")
    return "%s version %d" % (load(b), int.from_bytes(b[0:4], "little"))
def v4(flags, pad):
    b = bytearray(360)  # struct contego_kmod_load, version 4
    struct.pack_into("<IIQIIQ", b, 0, 4, 0, ctypes.addressof(image), len(img), 0, 0)
    struct.pack_into("<IIII", b, 48, 2, 0, 1, 1)   # ntasks 2, complain 0, sessions 1 and 1
    struct.pack_into("<IIII", b, 344, flags, 0xffffffff, 0xffffffff, pad)
    return "%s unsafe=%d" % (load(b), struct.unpack_from("<I", b, 348)[0])
print("size48", other(48, 0))
print("size344", other(344, 3))
print("version3", other(360, 3))
print("flags2", v4(2, 0))
print("pad1", v4(0, 1))
print("clean", v4(0, 0))
PY
run_logged requests python3 /tmp/kmod_requests.py
grep -q "^size48 EPROTO" "$OUT" && grep -q "^size344 EPROTO" "$OUT" && grep -q "^version3 EPROTO version 4" "$OUT" &&
  ok "a load request of another size or version is refused (EPROTO; the module's version 4 is sent back)" ||
  bad "another contego's load request: $(tr '\n' ';' <"$OUT")"
grep -q "^flags2 EINVAL" "$OUT" && grep -q "^pad1 EINVAL" "$OUT" && grep -q "^clean ok unsafe=0" "$OUT" &&
  ok "a load request with an unknown flag or a non-zero pad is refused (EINVAL); the same request without them loads" ||
  bad "hostile load requests: $(tr '\n' ';' <"$OUT")"

stop_reader
run_logged verify4 contego audit $AUDIT_LOG
[ $RC = 0 ] && ok "the log of the limits verifies" || bad "contego audit of the limits' log (exit $RC)"
for what in 'task 0 (arm_init): pid [0-9]* uid 1000 refused (EACCES).*"kind":"session-refused"' \
    'task 0 (arm_init): over its budget of 4 transfers per job.*"kind":"over-budget"'; do
  grep -q "$what" $AUDIT_LOG && ok "the module's log has $what" || bad "the module's log lacks $what"
done
back_to_i2c_dev

# `sessions 2`, the module's own limit on sessions (max_sessions) and the
# records' time. A copy of arm.policy whose arm_init may have 2 live
# sessions; the module loaded with max_sessions=2. Two scripts of arm_init
# act and live on: a third arm_init process is refused (EACCES), as the
# monitor refuses a hello over `sessions`. That refusal is made while the
# reader is stopped (SIGSTOP) and written seconds later: its line keeps the
# module's time of it. Then the same policy loaded again: the two sessions
# of the old load still count towards max_sessions (their processes live),
# so the third, which has room under the new load's `sessions`, is refused
# with EAGAIN: no room for one more session in the module, audited once
# for its two tries within a second.
AUDIT_LOG=$LOGDIR/kmod-sessions.jsonl
TWO=/tmp/arm-two.policy
awk '{ print } /^task arm_init \{/ { print "  sessions 2" }' $POLICIES/arm.policy >$TWO
rmmod i2c_dev
run_logged two_insmod insmod $KO adapters=0 buses=1 max_sessions=2
wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
start_reader $TWO
run_logged two_load1 contego kmod load --policy $TWO --bind arm_init=task --bind gripper=contego \
  --budget-factor 0
[ $RC = 0 ] && ok "kmod load: arm_init with sessions 2, module loaded with max_sessions=2" ||
  bad "kmod load of $TWO (exit $RC)"
two_pids=
for n in 1 2; do
  rm -f /tmp/two$n.pid
  as_task setsid sh -c "/usr/sbin/i2cset -y 0 0x40 0xfd 0 && echo \$\$ >/tmp/two$n.pid && exec sleep 600" \
    >"$LOGDIR/two$n.out" 2>&1 &
  wait_for /tmp/two$n.pid 10
  two_pids="$two_pids $(cat /tmp/two$n.pid 2>/dev/null)"
done
[ -s /tmp/two1.pid ] && [ -s /tmp/two2.pid ] &&
  ok "sessions 2: two scripts of arm_init act and live on (pids$two_pids)" ||
  bad "sessions 2: the scripts of arm_init did not both act: $(cat "$LOGDIR/two1.out" "$LOGDIR/two2.out")"
run_logged two_stats1 contego kmod stats
grep -q " sessions=2 " "$OUT" && ok "module counters: two live sessions" || bad "module counters with two scripts"
wall_us() { python3 -c 'import time; print(time.time_ns() // 1000)'; }
kill -STOP $READER_PID
t_before=$(wall_us)
run_logged two_third as_task python3 /tmp/kmod_second.py
t_after=$(wall_us)
sleep 3
kill -CONT $READER_PID
grep -q "^refused EACCES" "$OUT" &&
  ok "sessions 2: a third arm_init process is refused (EACCES) while two scripts have their sessions" ||
  bad "sessions 2: the third arm_init process: $(head -n 1 "$OUT")"
run_logged two_load2 contego kmod load --policy $TWO --bind arm_init=task --bind gripper=contego \
  --budget-factor 0
cat >/tmp/kmod_full.py <<'PY'
import errno, smbus
bus = smbus.SMBus(0)
for i in range(2):
    try:
        bus.write_byte_data(0x40, 0xfd, 0)
        print("written", flush=True)
    except OSError as e:
        print("refused", errno.errorcode[e.errno], flush=True)
PY
run_logged two_full as_task python3 /tmp/kmod_full.py
[ "$(grep -c '^refused EAGAIN' "$OUT")" = 2 ] &&
  ok "max_sessions=2, both open (the old load's): a new arm_init process is refused twice (EAGAIN)" ||
  bad "max_sessions=2: $(cat "$OUT")"
run_logged two_stats2 contego kmod stats
grep -q " sessions=2 .*sessions_refused=2 sessions_limited=1 " "$OUT" &&
  ok "module counters: two calls refused for room (sessions_refused=2), one for sessions" ||
  bad "module counters after the refusals: $(cat "$OUT")"
kill -KILL $two_pids
wait_sessions_closed
run_logged two_after as_task python3 /tmp/kmod_full.py
[ "$(grep -c '^written' "$OUT")" = 2 ] && ok "the scripts killed, their sessions ended: arm_init acts again" ||
  bad "after the scripts' end: $(cat "$OUT")"
stop_reader
run_logged verify5 contego audit $AUDIT_LOG
[ $RC = 0 ] && ok "the log of the sessions verifies" || bad "contego audit of the sessions' log (exit $RC)"
cat >/tmp/kmod_times.py <<'PY'
import json, sys
log, before, after = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
eacces = eagain = None
for line in open(log, encoding="utf-8", errors="replace"):
    line = line.strip("\0\n")
    if not line.startswith("{"):
        continue
    j = json.loads(line)
    if j.get("kind") != "session-refused":
        continue
    if "(EACCES)" in j["detail"]:
        eacces = j
    elif "(EAGAIN)" in j["detail"]:
        if eagain is not None:
            print("two EAGAIN lines:", eagain["detail"], "|", j["detail"])
            sys.exit(1)
        eagain = j
if eacces is None or eagain is None:
    print("missing:", "EACCES" if eacces is None else "", "EAGAIN" if eagain is None else "")
    sys.exit(1)
print("EACCES:", eacces["detail"])
print("EAGAIN:", eagain["detail"])
t = eacces["t_us"]
print("EACCES t_us %d, mono_us %s; the call ran in [%d, %d], the reader went on %.1f s after"
      % (t, eacces.get("mono_us"), before, after, (after + 3000000 - t) / 1e6))
# The refusal's time is the module's: inside the call, not the reader's
# writing 3 s later (the slack: the clocks read by another process).
ok = "mono_us" in eacces and before - 200000 <= t <= after + 200000
# Two tries within a second, one record: the first, counting itself.
ok = ok and "the module has 2 sessions open, its max_sessions; 1 call(s)" in eagain["detail"]
sys.exit(0 if ok else 1)
PY
run_logged times python3 /tmp/kmod_times.py $AUDIT_LOG $t_before $t_after
[ $RC = 0 ] &&
  ok "the EACCES refusal, written 3 s after it by a stopped reader, has the module's time of it; one EAGAIN line for two tries" ||
  bad "the session-refused lines' time or count: $(cat "$OUT")"
back_to_i2c_dev

# --- complain mode (docs/learn.md): the gripper's commands act as sent, the
# policy's verdicts are recorded, marked, and the log verifies.
AUDIT_LOG=$LOGDIR/kmod-complain.jsonl
stub_set $A 0xfe 0x79
stub_set $A 0x01 0x04
rmmod i2c_dev
run_logged complain_insmod insmod $KO adapters=0 buses=1
wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
start_reader
run_logged complain_load contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task \
  --bind gripper=contego --complain-for gripper
[ $RC = 0 ] && grep -q "COMPLAIN MODE for task(s) gripper" "$OUT" &&
  grep -q "complain mode for task mask 0x2" "$OUT" &&
  ok "kmod load --complain-for gripper: loaded, and loud about it" || bad "kmod load --complain-for (exit $RC)"
run_logged complain_prescale su contego -s /bin/sh -c "exec /usr/sbin/i2cset -y 0 $A 0xfe 3"
run_logged complain_enforced as_task i2cset -y 0 $A 0x01 0x10
stop_reader
back_to_i2c_dev
expect_reg $A 0xfe 3 "complain mode: the gripper's PRE_SCALE=3 (the policy ignores it) acted as sent"
expect_reg $A 0x01 0x04 "arm_init, not in complain mode, is still enforced: its MODE2=0x10 did not land"
run_logged complain_verify contego audit $AUDIT_LOG
[ $RC = 0 ] && grep -q '"complain":true,"decision":"ignore".*"task_name":"gripper"' $AUDIT_LOG &&
  ok "the log records the would-be verdict (ignore) marked complain, and verifies" ||
  bad "no verified complain record of the gripper's PRE_SCALE write"

# --- signed bundles (docs/deployment.md): `kmod load --require-signed` loads
# a bundle whose minisign signature verifies, and refuses a changed one
# before the module sees it (the policy in force stays).
if [ -f /vm/keys/robot.pub ]; then
  AUDIT_LOG=$LOGDIR/kmod-signed.jsonl
  rmmod i2c_dev
  run_logged signed_insmod insmod $KO adapters=0 buses=1
  wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
  start_reader
  run_logged signed_load contego kmod load --bundle /vm/policies/arm.bundle --require-signed \
    --keys-dir /vm/keys --bind arm_init=task --bind gripper=contego
  [ $RC = 0 ] && grep -q "loaded" "$OUT" &&
    ok "kmod load --bundle --require-signed: a signed bundle verified and in force" ||
    bad "kmod load of the signed bundle (exit $RC)"
  run_logged changed_load contego kmod load --bundle /vm/policies/arm-changed.bundle \
    --require-signed --keys-dir /vm/keys --bind arm_init=task --bind gripper=contego
  [ $RC = 2 ] && grep -q "does not match the signed data" "$OUT" &&
    ok "a changed bundle is refused before the module sees it: $(grep -o 'signature by key ID [0-9A-F]*' "$OUT")" ||
    bad "a changed signed bundle: exit $RC"
  run_logged unsigned_load contego kmod load --policy $POLICIES/arm.policy --require-signed
  [ $RC = 2 ] && grep -q "require-signed" "$OUT" && ok "--require-signed refuses a policy source" ||
    bad "--require-signed with --policy: exit $RC"
  run_logged signed_stats contego kmod stats
  grep -q "loaded=1 loads=1 refused_loads=0" "$OUT" &&
    ok "module counters after the refusals: the one signed load, nothing else reached it" ||
    bad "module counters after the signed loads: $(cat "$OUT")"
  stop_reader
  back_to_i2c_dev
else
  echo "  skipped: the signed bundle checks (no minisign or host contego when the initramfs was made)"
fi

# --- load in place (`contego kmod reload`): a changed policy while arm_init
# holds LED5 at 577 in a live session. No safe state is driven, the session
# goes on under the new policy (its end still drives the safe state); a
# policy whose device moved is refused before the module sees it.
AUDIT_LOG=$LOGDIR/kmod-reload.jsonl
rmmod i2c_dev
run_logged reload_insmod insmod $KO adapters=0 buses=1
wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
start_reader
run_logged reload_fresh contego kmod reload --policy $POLICIES/arm.policy --bind arm_init=task
[ $RC = 1 ] && grep -q "no policy is in force" "$OUT" &&
  ok "kmod reload with nothing loaded: refused (exit 1), $(cat "$OUT")" || bad "kmod reload with nothing loaded: exit $RC"
run_logged reload_load contego kmod load --policy $POLICIES/arm.policy --bind arm_init=task --bind gripper=contego \
  --budget-factor 0
start_led5_holder
sed 's/^limit gripper -> arm.led 1 per job/limit gripper -> arm.led 2 per job/' $POLICIES/arm.policy >/tmp/arm-more.policy
run_logged reload_inplace contego kmod reload --policy /tmp/arm-more.policy --bind arm_init=task \
  --bind gripper=contego --budget-factor 0
[ $RC = 0 ] && grep -q "loaded in place" "$OUT" && grep -q "no safe state driven" "$OUT" &&
  ok "kmod reload: $(cat "$OUT")" || bad "kmod reload in place: exit $RC"
[ "$(led5)" = 577 ] && kill -0 "$HOLDER" 2>/dev/null &&
  ok "after the reload LED5 off = 577 still (no safe state driven) and the session's program runs (pid $HOLDER)" ||
  bad "after the reload LED5 off reads $(led5), the holder $(kill -0 "$HOLDER" 2>/dev/null && echo runs || echo is gone)"
dmesg | grep -q "contego: policy loaded in place" && ok "the kernel log: $(dmesg | grep -o 'contego: policy loaded in place.*' | tail -n1)" ||
  bad "no load in place in the kernel log"
# `contego kmod status`: the image in force, as its SHA-256 (the one
# `contego check --emit` prints), its names, the reader, the sessions.
want=$(contego check /tmp/arm-more.policy --emit /tmp/arm-more.img 2>&1 >/dev/null | sed -n 's/.*SHA-256 \([0-9a-f]*\)).*/\1/p')
run_logged kstatus contego kmod status
[ $RC = 0 ] && [ -n "$want" ] && grep -q "image SHA-256 $want" "$OUT" && grep -q "tasks: *arm_init, gripper" "$OUT" &&
  grep -q "a reader is attached" "$OUT" && grep -q "sessions: [1-9][0-9]* open" "$OUT" &&
  ok "kmod status names the reloaded image (SHA-256 ${want:0:12}...), its tasks, the reader and the live session" ||
  bad "kmod status (exit $RC), expected image SHA-256 $want"
run_logged kstatus_json contego kmod status --json
python3 -c 'import json, sys; s = json.load(open(sys.argv[1])); assert s["loaded"] and s["image_sha256"] == sys.argv[2] and s["counters"]["sessions"] >= 1, s' \
  "$OUT" "$want" 2>/dev/null && ok "kmod status --json: the same as JSON" || bad "kmod status --json: $(cat "$OUT")"
# A 32-bit caller (i386 here, armhf on a Pi's arm64 kernel) drives the
# control node through compat_ioctl: STATS, then IMAGE's size probe and the
# image itself, the same size and CRC-32 as the 64-bit `kmod status --json`.
if [ -x /vm/attack/kmod_ctl32 ]; then
  cp "$OUT" /tmp/kstatus.json
  run_logged kmod_ctl32 /vm/attack/kmod_ctl32
  python3 - "$OUT" /tmp/kstatus.json <<'PY' 2>/dev/null &&
import json, sys
got = {l.split()[0]: (int(l.split()[1]), int(l.split()[2])) for l in open(sys.argv[1]) if l.strip()}
s = json.load(open(sys.argv[2]))
assert got["open"][0] == 0 and got["stats-loaded"] == (0, 1) and got["stats-checks"][1] > 0, got
assert got["image-probe"] == (-28, s["image_bytes"]), got  # ENOSPC with the size needed
assert got["image-size"] == (0, s["image_bytes"]), got
assert got["image-crc"] == (0, int(s["image_crc32"], 16)), got
assert got["image-magic"][1] != 0, got
PY
    ok "a 32-bit program drives /dev/contego through compat_ioctl: stats, the image's size probe (ENOSPC) and the image ($(grep image-size "$OUT"), CRC as kmod status)" ||
    bad "32-bit control requests: $(tr '\n' ';' <"$OUT")"
else
  echo "VM-CHECK SKIP $SCENARIO: no 32-bit control-node program (built on x86-64 hosts only)"
fi
sed 's/^device arm : pca9685 at i2c-1 0x40/device arm : pca9685 at i2c-1 0x41/' $POLICIES/arm.policy >/tmp/arm-moved.policy
run_logged reload_moved contego kmod reload --policy /tmp/arm-moved.policy --bind arm_init=task
[ $RC = 1 ] && grep -q "the policy in force stays" "$OUT" && grep -q "keeps the devices" "$OUT" &&
  ok "a reload whose device moved is refused: $(cat "$OUT")" || bad "a reload with a moved device: exit $RC"
run_logged reload_stats contego kmod stats
grep -q "loads=2 refused_loads=0" "$OUT" && ok "module counters: the load and the load in place, nothing else reached it" ||
  bad "module counters after the reloads: $(cat "$OUT")"
kill "$HOLDER"
led5_becomes 420 && ok "the session opened before the reload ended after it: its end drove LED5 off = 420" ||
  bad "after the holder's end LED5 off reads $(led5), expected the safe state 420"
# A load whose actuator cannot be driven to its safe state (arm at 0x41,
# where no chip answers) is refused, as the monitor refuses to start: the
# policy in force stays and still decides; --allow-degraded loads it anyway.
run_logged unsafe_load contego kmod load --policy /tmp/arm-moved.policy --bind arm_init=task --budget-factor 0
[ $RC = 1 ] && grep -q "load refused: the safe state of arm (i2c-1 0x41) could not be driven" "$OUT" &&
  grep -q "the policy in force stays (--allow-degraded loads anyway)" "$OUT" &&
  ok "a load whose safe state cannot be driven is refused: $(cat "$OUT")" || bad "a load with an undrivable safe state: exit $RC"
run_logged unsafe_status contego kmod status
grep -q "image SHA-256 $want" "$OUT" && ok "the image in force before it stays in force (SHA-256 ${want:0:12}...)" ||
  bad "after the refused load: $(cat "$OUT")"
# The refused policy has no device at 0x40: under it this call would be
# refused (exit 1); the one in force decides it (allowed or ignored: exit 0).
run_logged unsafe_set as_task i2cset -y 0 $A 0x01 0x04
[ $RC = 0 ] && ok "the policy in force still decides: arm_init's i2cset MODE2 at 0x40 exits 0" ||
  bad "after the refused load arm_init's i2cset at 0x40 exits $RC"
dmesg | grep -q "contego: policy refused: sensor(s) 0x0 could not be read, the safe state of device(s) 0x1 could not be driven; the policy in force stays" &&
  ok "the kernel log: $(dmesg | grep -o 'contego: policy refused: the safe state.*' | tail -n1)" ||
  bad "no refused load in the kernel log"
run_logged degraded_load contego kmod load --policy /tmp/arm-moved.policy --bind arm_init=task --budget-factor 0 \
  --allow-degraded
[ $RC = 0 ] && grep -q "allow-degraded: loaded although the safe state of arm (i2c-1 0x41) could not be driven" "$OUT" &&
  ok "kmod load --allow-degraded: in force, and loud about it" || bad "kmod load --allow-degraded: exit $RC"
run_logged degraded_status contego kmod status
grep -q "^DEGRADED: the safe state of arm (i2c-1 0x41) not driven since the load" "$OUT" &&
  ok "kmod status says so: $(grep DEGRADED "$OUT")" || bad "kmod status after the degraded load: $(cat "$OUT")"
stop_reader
grep -q 'withdrawn after its load (a device absent, or no form on its adapter): safe state of device(s) 0 (.*"kind":"policy-load-refused"' $AUDIT_LOG &&
  ok "the log records the withdrawn load and names the device" || bad "no withdrawn load in the module's log"
grep -q 'in place (state carried over from image CRC-32 [0-9a-f]*, no safe state driven)' $AUDIT_LOG &&
  ok "the log names the load in place and the image it replaced" || bad "no load in place in the module's log"
run_logged reload_verify contego audit $AUDIT_LOG
[ $RC = 0 ] && ok "contego audit verifies the log across the load in place" || bad "contego audit exit $RC"
back_to_i2c_dev

[ $FAILS = 0 ] || { echo "  the gripper's decisions (kernel log, trace=1):"; show "$LOGDIR/grip-trace"; }
finish
