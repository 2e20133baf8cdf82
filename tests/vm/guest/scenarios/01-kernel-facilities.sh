# The tests whose subject is the kernel, run on Debian's kernel: the seccomp
# filter's tests, and among them the i386 entry (int 0x80), which a host
# kernel without IA-32 emulation can only skip. Debian's amd64 kernel has
# IA-32 emulation, so here the test must run and pass, not skip. On arm64
# (tests/vm/arm64.sh) the filter must pass with the aarch64 numbers.
. /vm/lib.sh
t=/vm/bin/seccomp_filter_test
[ -x $t ] || { bad "no $t in the guest (run.sh --test-binary)"; finish; }
run_logged filter $t
[ $RC = 0 ] && ok "seccomp_filter_test passes on Debian's $(uname -m) kernel" || bad "seccomp_filter_test exit $RC"
case "$(uname -m)" in
  x86_64)
    grep -q "^\[       OK \] SeccompFilter.I386SystemCallKillsTheProcess" "$OUT" &&
      ok "SeccompFilter.I386SystemCallKillsTheProcess runs and passes (IA-32 emulation present)" ||
      { bad "SeccompFilter.I386SystemCallKillsTheProcess did not pass here"; grep -A2 I386 "$OUT"; }
    ;;
  *)
    # No other entry than the native one is compiled in there; nothing may
    # skip on the real kernel (seccomp, user notification, pidfd are all in).
    if grep -q "^\[  SKIPPED \]" "$OUT"; then
      bad "seccomp_filter_test skipped tests on $(uname -m): $(grep '^\[  SKIPPED \] [A-Z]' "$OUT" | tr '\n' ' ')"
    else
      ok "no seccomp_filter_test case skipped on $(uname -m)"
    fi
    ;;
esac
finish
