# The unit and integration tests of the build under test, run on Debian's
# kernel of the guest's architecture: every GoogleTest binary in /vm/bin
# other than the seccomp filter's (scenario 01). The arm64 bed gives the
# core, policy, monitor, bus, gate and supervisor tests (run.sh --arch arm64
# from tests/vm/arm64.sh); the amd64 bed runs them on the host and gives none.
. /vm/lib.sh
ran=0
for t in /vm/bin/*_test; do
  [ -x "$t" ] || continue
  name=${t##*/}
  [ "$name" = seccomp_filter_test ] && continue
  ran=$((ran + 1))
  # Every test named in the log: a test that hangs is then the last one started.
  run_logged "$name" "$t"
  summary=$(grep -a '^\[  PASSED  \]' "$OUT" | head -n1)
  skipped=$(grep -a '^\[  SKIPPED \]' "$OUT" | head -n1)
  if [ $RC = 0 ]; then
    ok "$name passes on $(uname -m): ${summary#\[  PASSED  \] }${skipped:+, ${skipped#\[  SKIPPED \] } skipped}"
  else
    bad "$name exit $RC on $(uname -m)"
  fi
done
[ $ran -gt 0 ] || ok "no test binaries for this architecture (the host runs them)"
finish
