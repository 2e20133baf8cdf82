# contego.ko with many bound sessions (issue 40 item 2, kernel half;
# docs/performance.md "Sessions under contego.ko"). kmod_sessions
# (tests/intercept/testcases/kmod_sessions.c) forks N processes, each its own
# session of one of 32 tasks (bound by uid 2000..2031), each a periodic task
# writing the PCA9685 at 0x40 (3 SMBus writes per 10 ms job), first under the
# plain i2c-dev and then under contego.ko, same boot, then back to back for
# 1 s; one table row per N. Then the module's session cap (max_sessions,
# 1,024 by default): of 1,025 live writers the one without room is refused
# EAGAIN and counted, and once they exit a second round of 1,024 works.
#
# CI runs a smoke: N = 1 and 16, 20 jobs. The full sweep is
#   CONTEGO_VM_APPEND="contego.timeout=3000 contego.kmod_sessions=1,4,16,64,256,1024 contego.kmod_jobs=50" \
#     [contego.kmod_reader_nice=-10 in it: the audit reader at that nice value]
#     bash tests/vm/run.sh --timeout 3600 --attack-binary build/dev/tests/intercept/kmod_sessions \
#     --scenarios 63-kmod-sessions
. /vm/lib.sh
. /vm/inc/kmod.sh
PROG=/vm/attack/kmod_sessions
kmod_built_or_skip
[ -x $PROG ] || { bad "no $PROG (run.sh --attack-binary build/dev/tests/intercept/kmod_sessions)"; finish; }
COUNTS=1,16 JOBS=20 READER_NICE=0
for arg in $(cat /proc/cmdline); do
  case "$arg" in
    contego.kmod_sessions=*) COUNTS=${arg#*=} ;;
    contego.kmod_jobs=*) JOBS=${arg#*=} ;;
    # The audit reader's nice value (e.g. -10): with hundreds of writers
    # it is one process among them, and its share of the CPU falls.
    contego.kmod_reader_nice=*) READER_NICE=${arg#*=} ;;
  esac
done

# 32 tasks on the one PCA9685, each may have 64 live sessions (the most a
# policy may give): 2,048 in all, so the module's max_sessions (1,024) is
# the limit the 1,025th process meets, not a task's `sessions`.
POLICY=/tmp/sessions.policy
BINDS=
{
  echo 'device arm : pca9685 at i2c-1 0x40 { safe led(5, on=0, off=420) }'
  echo 'invariant RANGE on arm.led: require off <= 600 else ignore'
  i=0
  while [ $i -lt 32 ]; do
    printf 'task t%d {\n  period 10ms; deadline 10ms; wcet 100us; priority 1\n  actuations 3\n  sessions 64\n}\n' $i
    echo "allow t$i -> arm"
    BINDS="$BINDS --bind t$i=$((2000 + i))"
    i=$((i + 1))
  done
} >$POLICY
AUDIT_LOG=$LOGDIR/sessions-audit.jsonl

# The two ways the adapter is served, as scripts kmod_sessions runs between
# its phases: i2c-dev (the plain adapter) and contego.ko (policy loaded,
# audit reader attached; --budget-factor 0: back to back, every task is far
# over its actuations, and the hold would time the hold, not the check).
cat >/tmp/to_plain.sh <<EOF
pid=\$(cat /tmp/ks-reader.pid 2>/dev/null)
if [ -n "\$pid" ]; then
  kill -TERM \$pid; while kill -0 \$pid 2>/dev/null; do usleep 50000; done
  rm -f /tmp/ks-reader.pid $AUDIT_LOG  # one round's log at a time in the guest's memory
fi
if grep -q '^contego ' /proc/modules; then rmmod contego || exit 1; fi
grep -q '^i2c_dev ' /proc/modules || insmod /lib/modules/i2c-dev.ko || exit 1
i=0; while [ ! -e /dev/i2c-0 ]; do i=\$((i + 1)); [ \$i -gt 100 ] && exit 1; usleep 100000; done
chmod 0666 /dev/i2c-0
EOF
cat >/tmp/to_kmod.sh <<EOF
rmmod i2c_dev || exit 1
insmod $KO adapters=0 buses=1 || exit 1
i=0; while [ ! -e /dev/i2c-0 ] || [ ! -e /dev/contego ]; do i=\$((i + 1)); [ \$i -gt 100 ] && exit 1; usleep 100000; done
chmod 0666 /dev/i2c-0
contego kmod audit --policy $POLICY --audit $AUDIT_LOG >>$LOGDIR/reader.log 2>&1 &
echo \$! >/tmp/ks-reader.pid
[ $READER_NICE = 0 ] || renice $READER_NICE -p \$! >/dev/null || exit 1
i=0; until contego kmod stats 2>/dev/null | grep -q "reader=1"; do i=\$((i + 1)); [ \$i -gt 100 ] && exit 1; usleep 100000; done
contego kmod load --policy $POLICY $BINDS --budget-factor 0 >>$LOGDIR/load.log 2>&1
EOF

klog_mark sessions
echo "  sessions sweep: N = $COUNTS, $JOBS jobs each, audit reader at nice $READER_NICE, ${ACCEL:-unknown accelerator} ($(nproc) vCPUs)"
run_logged sweep $PROG sweep $COUNTS $JOBS "sh /tmp/to_plain.sh" "sh /tmp/to_kmod.sh"
[ $RC = 0 ] && tail -n 1 "$OUT" | grep -q '^ok$' &&
  ok "kmod_sessions sweep N=$COUNTS: every write of every process, plain and checked, succeeded; every session reclaimed" ||
  bad "kmod_sessions sweep (exit $RC)"
rows=$(grep -cE '^ *[0-9]+ +[0-9]+ \|' "$OUT")
[ "$rows" = "$(echo $COUNTS | tr ',' '\n' | wc -l)" ] && ok "one row per N ($rows)" || bad "$rows rows for N=$COUNTS"
# The module's own count of each round's periodic writes: every one checked
# and performed (N x JOBS x 3), none refused, no record lost. Back to back
# the reader may fall behind and calls fail closed (EIO): counted, reported
# in the row, not a failure of the module.
bad_rows=$(awk -v jobs=$JOBS '/^ *[0-9]+ +[0-9]+ \|/ { n = $1 }
  /^ *periodic:/ { want = "+" n * jobs * 3; if ($3 != want || $5 != want || $7 != "+0" || $9 != "+0;") print }' "$OUT")
[ -z "$bad_rows" ] && [ "$(grep -c '^ *periodic:' "$OUT")" = "$rows" ] &&
  ok "the module checked and performed every periodic write of every round (N x $JOBS x 3), refused none, lost no record" ||
  bad "the module's counts of the periodic writes: $bad_rows"
stop_reader_file() {
  pid=$(cat /tmp/ks-reader.pid 2>/dev/null)
  [ -n "$pid" ] || return 1
  kill -TERM "$pid"; while kill -0 "$pid" 2>/dev/null; do usleep 50000; done
  rm -f /tmp/ks-reader.pid
}

# The cap, with contego.ko loaded afresh (reader attached, policy loaded):
# the last round's back-to-back second may have left the ring full of
# records the reader has yet to write, and a write that finds no room
# fails closed (EIO), which is not what this measures.
run_logged reload sh -c "sh /tmp/to_plain.sh && sh /tmp/to_kmod.sh"
[ $RC = 0 ] || bad "contego.ko reloaded for the cap (exit $RC)"
run_logged cap1025 $PROG cap 1025
grep -q '^cap n=1025 written=1024 eagain=1 other=0 open=1024 sessions_refused=+1 reclaimed_ms=[0-9]' "$OUT" &&
  ok "1,025 live writers: 1,024 sessions open, the 1,025th refused EAGAIN and counted; all reclaimed after the exits ($(sed -n 's/.*reclaimed_ms=\([0-9]*\).*/\1/p' "$OUT") ms)" ||
  bad "the 1,025th session: $(cat "$OUT")"
run_logged cap1024 $PROG cap 1024
grep -q '^cap n=1024 written=1024 eagain=0 other=0 open=1024 sessions_refused=+0 reclaimed_ms=[0-9]' "$OUT" &&
  ok "a second round of 1,024 writers after the first exited: all 1,024 sessions open again, none refused, all reclaimed" ||
  bad "the second round of 1,024: $(cat "$OUT")"
run_logged stats contego kmod stats
grep -q " sessions=0 " "$OUT" && ok "no session left open" || bad "sessions left open: $(cat "$OUT")"
stop_reader_file
run_logged verify contego audit $AUDIT_LOG
[ $RC = 0 ] && [ "$(grep '"kind":"session-refused"' $AUDIT_LOG | grep -c '(EAGAIN)')" = 1 ] &&
  ok "the log verifies and has the one EAGAIN refusal" || bad "the log (contego audit exit $RC): $(grep EAGAIN $AUDIT_LOG | head -n 2)"
klog_since sessions | grep -E "BUG|Oops|WARNING|general protection|hung task" >/tmp/ks-klog.bad
[ -s /tmp/ks-klog.bad ] && bad "kernel log: $(head -n 1 /tmp/ks-klog.bad)" || ok "no kernel warning"
rm -f $AUDIT_LOG
back_to_i2c_dev
finish
