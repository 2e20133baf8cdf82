# A small overhead bench: the same client (i2c-write-loop: N SMBus byte-data
# writes in one process, each timed) on the plain adapter and under contego
# (embedded monitor, and the monitor daemon with the task as uid 1000),
# side by side. Under TCG (no KVM) every figure is emulation-bound: only the
# ratio between rows means something, and only roughly.
. /vm/lib.sh
N=${BENCH_N:-2000}
A=0x40 REG=0xfd  # ALL_LED_OFF_H = 0: allowed to arm_init any number of times
loop="i2c-write-loop"
BUS_ARGS="$BUS_ARGS --budget-factor 0"  # a bench task far over its declared actuations

run_logged plain $loop 0 $A $REG 0 $N
plain=$(cat "$OUT")
run_logged embedded contego run --policy $POLICIES/arm.policy $BUS_ARGS --user 1000 --task arm_init \
  --audit $LOGDIR/bench-audit.jsonl -- $loop 1 $A $REG 0 $N
embedded=$(grep '^loop' "$OUT")
start_monitor arm.policy || finish
run_logged monitor as_task contego run --socket $SOCK --task arm_init -- $loop 1 $A $REG 0 $N
monitor=$(grep '^loop' "$OUT")
stop_monitor

field() { echo "$1" | sed -n "s/.*$2=\([0-9.]*\).*/\1/p"; }
accel=${ACCEL:-unknown accelerator}  # from the host, on the kernel command line
echo "  bench: $N writes per row, $accel ($(nproc) vCPUs)."
[ "$accel" = KVM ] || echo "  bench: TCG emulates every instruction; these timings are only indicative."
printf '  %-34s %10s %10s %10s %12s %12s %12s %8s\n' row median_us p99_us worst_us added_median added_p99 added_worst ratio
for row in plain embedded monitor; do
  eval line=\$$row
  if ! echo "$line" | grep -q 'errors=0'; then bad "bench row $row did not complete: $line"; continue; fi
  m=$(field "$line" median_us) p=$(field "$line" p99_us) w=$(field "$line" max_us)
  pm=$(field "$plain" median_us) pp=$(field "$plain" p99_us) pw=$(field "$plain" max_us)
  case $row in
    plain) label="plain /dev/i2c-0" ;;
    embedded) label="contego run --policy (c1)" ;;
    monitor) label="contego run --socket, uid 1000 (c2)" ;;
  esac
  awk -v l="$label" -v m=$m -v p=$p -v w=$w -v pm=$pm -v pp=$pp -v pw=$pw 'BEGIN {
    printf "  %-34s %10.1f %10.1f %10.1f %12.1f %12.1f %12.1f %7.1fx\n", l, m, p, w, m - pm, p - pp, w - pw, m / pm }'
  ok "bench row $row: $N writes, no errors"
done
# Every bench write went to the stub: LED0_ON_L is still 0 and nothing else moved.
stub_set $A $REG 0x11
run_logged last contego run --policy $POLICIES/arm.policy $BUS_ARGS --user 1000 --task arm_init --audit $LOGDIR/last-audit.jsonl -- $loop 1 $A $REG 0 1
expect_reg $A $REG 0 "a bench write lands (ALL_LED_OFF_H = 0)"
finish
