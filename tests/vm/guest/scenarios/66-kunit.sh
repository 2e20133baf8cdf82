# KUnit on the test bed's kernel (docs/kernel-client.md, "KUnit"): the pure
# parts of contego.ko -- the i2c-dev model it shares with the monitor
# (planning, the SMBus call table, the retry rule of I2C_RETRIES and
# I2C_TIMEOUT, the job grid and the hold's counts, the message flag
# allow-list) as the kernel's build compiles them, and the
# session room rule -- tested in the kernel. kunit.ko is Debian's own KUnit
# built out of tree (kernel/kunit/unpack.sh), since Debian's kernel has
# none; its results are KTAP in the kernel log.
. /vm/lib.sh
KUNIT=/lib/modules/kunit.ko
TESTS=/lib/modules/contego-kunit.ko
if [ ! -f $TESTS ]; then
  why=$(cat /lib/modules/kunit-skipped 2>/dev/null || echo "not built (no kernel headers on the host)")
  echo "VM-CHECK SKIP $SCENARIO: the KUnit modules were not built: $why"
  exit 0
fi

echo "contego-test: mark kunit" >/dev/kmsg
run_logged kunit insmod $KUNIT enable=1
[ $RC = 0 ] && ok "kunit.ko loads (enable=1)" || { bad "insmod kunit.ko (exit $RC)"; finish; }
run_logged tests insmod $TESTS
[ $RC = 0 ] && ok "contego-kunit.ko loads and runs its suites" || bad "insmod contego-kunit.ko (exit $RC)"
# The log from the mark on, without its time stamps: KTAP.
dmesg | sed -n '/contego-test: mark kunit$/,$p' | sed 's/^\[[^]]*\] //' >$LOGDIR/kunit.ktap
# Each case is "ok N name" or "not ok N name", indented inside its suite;
# each suite's own line is at the top level.
cases_ok=$(grep -cE '^    ok [0-9]+ ct_kunit_' $LOGDIR/kunit.ktap || true)
cases_bad=$(grep -cE '^ *not ok [0-9]+ ' $LOGDIR/kunit.ktap || true)
suites_ok=$(grep -cE '^ok [0-9]+ contego_' $LOGDIR/kunit.ktap || true)
grep -vE '^contego-test: mark' $LOGDIR/kunit.ktap | sed 's/^/    | /'
[ "$cases_bad" = 0 ] && [ "$cases_ok" -ge 12 ] && ok "KUnit: $cases_ok cases passed, 0 failed" ||
  bad "KUnit: $cases_ok cases passed, $cases_bad failed (expected 12 passed, 0 failed)"
[ "$suites_ok" = 2 ] && ok "KUnit: both suites (contego_i2c_model, contego_budget_and_sessions) ok" ||
  bad "KUnit: $suites_ok of 2 suites ok"
dmesg | sed -n '/contego-test: mark kunit$/,$p' | grep -qE 'BUG:|WARNING:|Oops' &&
  bad "the kernel warned while KUnit ran" || ok "no kernel warning while KUnit ran"
rmmod contego_kunit && rmmod kunit && ok "both modules unload" || bad "rmmod contego_kunit kunit"
finish
