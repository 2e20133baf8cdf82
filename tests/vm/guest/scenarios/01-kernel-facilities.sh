# The tests whose subject is the kernel, run on Debian's kernel: the seccomp
# filter's tests, and among them the i386 entry (int 0x80), which a host
# kernel without IA-32 emulation can only skip. Debian's amd64 kernel has
# IA-32 emulation, so here the test must run and pass, not skip.
. /vm/lib.sh
t=/vm/bin/seccomp_filter_test
[ -x $t ] || { bad "no $t in the guest (run.sh --test-binary)"; finish; }
run_logged filter $t
[ $RC = 0 ] && ok "seccomp_filter_test passes on Debian's kernel" || bad "seccomp_filter_test exit $RC"
grep -q "^\[       OK \] SeccompFilter.I386SystemCallKillsTheProcess" "$OUT" &&
  ok "SeccompFilter.I386SystemCallKillsTheProcess runs and passes (IA-32 emulation present)" ||
  { bad "SeccompFilter.I386SystemCallKillsTheProcess did not pass here"; grep -A2 I386 "$OUT"; }
finish
