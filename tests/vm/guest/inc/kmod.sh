# contego.ko's helpers, shared by the scenarios that load it (60, 61):
# the audit reader (`contego kmod audit`, which the module needs before any
# call may act) and the way back to the plain i2c-dev. Set AUDIT_LOG first.
KO=/lib/modules/contego.ko

# Not a failure when the module was not built: the host had no linux-headers
# for this kernel (tools/bootstrap.sh). The scenario reports a skip and ends.
kmod_built_or_skip() {
  [ -f $KO ] && return 0
  echo "VM-CHECK SKIP $SCENARIO: contego.ko was not built (no kernel headers on the host)"
  exit 0
}

# The kernel log from a mark on: `dmesg | tail -n +N` loses its place once
# the log's ring wraps (scenario 63 fills it with session ends).
# A mark the ring has dropped since: all of the log is after it.
klog_mark() { echo "contego-test: mark $1" >/dev/kmsg; }
klog_since() {
  dmesg >/tmp/klog.all
  if grep -q "contego-test: mark $1\$" /tmp/klog.all; then
    sed -n "/contego-test: mark $1\$/,\$p" /tmp/klog.all
  else
    cat /tmp/klog.all
  fi
}

# LED5 off of the PCA9685 at 0x40 as arm_init (uid 1000) reads it through
# contego.ko (a read opens no session).
led5() {
  lo=$(as_task i2cget -y 0 0x40 0x1c) && hi=$(as_task i2cget -y 0 0x40 0x1d) && echo $(( (hi << 8) | lo ))
}
led5_becomes() {  # led5_becomes VALUE: waits up to 5 s (a session ends from the module's work queue)
  i=0
  while [ "$(led5)" != "$1" ]; do
    i=$((i + 1)); [ $i -gt 50 ] && return 1
    usleep 100000
  done
}

READER_PID=
start_reader() {  # start_reader [POLICY [ARGS...]]: the policy whose names the log gets (arm.policy)
  reader_policy=${1:-$POLICIES/arm.policy}
  [ $# -gt 0 ] && shift
  contego kmod audit --policy $reader_policy --audit $AUDIT_LOG "$@" >>"$LOGDIR/reader.log" 2>&1 &
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

# contego.ko out, i2c-dev back in: every adapter gets its plain node again.
back_to_i2c_dev() {
  rmmod contego 2>/dev/null
  insmod /lib/modules/i2c-dev.ko && own_adapter
}

# Waits (up to 5 s) until the module counts no open session: a killed task's
# session ends when its last file is released, a moment after the kill.
wait_sessions_closed() {
  local i=0
  until contego kmod stats | grep -q " sessions=0 "; do
    i=$((i + 1)); [ $i -gt 50 ] && return 1
    usleep 100000
  done
}

# A live session of arm_init holding LED5 off = 577: a script (its own
# process group, as a shell gives it) that wrote 420 then 577 and sleeps,
# holding no descriptor of the node. Sets HOLDER (its pid; empty if it
# did not get that far).
start_led5_holder() {
  rm -f /tmp/holder.pid
  as_task setsid sh -c '/usr/sbin/i2cset -y 0 0x40 0x1a 0 0 0xa4 0x01 i && /usr/sbin/i2cset -y 0 0x40 0x1a 0 0 0x41 0x02 i && echo $$ >/tmp/holder.pid && exec sleep 600' \
    >"$LOGDIR/holder.out" 2>&1 &
  wait_for /tmp/holder.pid 10
  HOLDER=$(cat /tmp/holder.pid 2>/dev/null)
}

# decisions LOG TASK: one line per decision of TASK in an audit log, the
# fields both clients write: command, verdict, reason, rule, the command's
# first 24 bytes (what contego.ko's record keeps; the monitor's keeps all)
# and the decoded fields. Scenarios 62 and 65 compare the two clients' logs.
decisions() {
  python3 - "$1" "$2" <<'PY'
import json, sys
for line in open(sys.argv[1], encoding="utf-8", errors="replace"):
    line = line.strip("\0\n")
    if not line.startswith("{"):
        continue
    j = json.loads(line)
    if j.get("kind") == "decision" and j.get("task_name") == sys.argv[2]:
        print(j.get("command_name", "-"), j["decision"], j.get("reason_name"),
              j.get("rule_name", "-"), " ".join((j.get("bytes") or "").split()[:24]),
              j.get("fields"))
PY
}
