#!/usr/bin/env bash
# The real-kernel test bed, host side: fetches Debian's kernel (cached),
# packs the guest initramfs around the freshly built contego, boots it once in
# QEMU (KVM when it works here, TCG otherwise: accel.sh) under a hard time limit,
# and judges the serial console: every scenario must report PASS and the
# guest must say it finished. Missing QEMU or kernel is a failure, never a
# skip: CI must not go green without having run anything.
#
# Usage: tests/vm/run.sh [--arch amd64|arm64] [--contego PATH] [--bench-client PATH]
#                        [--test-binary PATH]... [--attack-binary PATH]...
#                        [--mirror PATH]... [--workdir DIR]
#                        [--scenarios a,b,...] [--shell] [--timeout SECONDS]
#                        [--skip-code N] [--gtest-filter PATTERN]
#   --arch arm64 Debian's arm64 kernel in qemu-system-aarch64 (-M virt,
#                Cortex-A53), its i2c-stub cross-built (fetch-kernel.sh), its
#                user space from Debian's arm64 packages (fetch-userland.sh);
#                the binaries given must be the cross-built ones
#   --attack-binary  an attack program of tests/intercept (attack_*), put in
#                the guest's /vm/attack for scenario 61 (contego.ko and the
#                monitor on the plain-I2C adapter); default: the dev build's,
#                when built
#   --mirror     a host path copied to the same path in the guest (test data
#                a test binary names at compile time)
#   --skip-code  exit N instead of failing when QEMU or a cross tool is
#                missing (CTest's SKIP_RETURN_CODE for the optional arm64 bed)
#   --gtest-filter  GTEST_FILTER for the test binaries the guest runs
#                (scenario 02), e.g. '-*/seccomp_socket'; no spaces
#   --shell      boot to an interactive shell on this terminal instead (run
#                one scenario by hand: sh /vm/scenarios/NAME.sh; leave: poweroff -f)
# Defaults: the dev build's binaries (build/dev), workdir build/dev/tests/vm.
# Env: CONTEGO_VM_CACHE (kernel cache, see fetch-kernel.sh),
#      CONTEGO_VM_TIMEOUT (default 900 s for the whole boot),
#      CONTEGO_VM_APPEND (more kernel command line for the guest: e.g.
#      contego.timeout=N, a scenario's own options such as 63's
#      contego.kmod_sessions=COUNTS).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
contego=$src/build/dev/src/cli/contego
bench_client=$src/build/dev/tests/vm/i2c-write-loop
test_binaries=()  # GoogleTest binaries run in the guest (scenario 01)
attack_binaries=()  # tests/intercept's attack programs (scenario 61)
workdir=$src/build/dev/tests/vm
mirrors=()
scenarios=all shell=0 arch=amd64 skip_code="" gtest_filter=""
limit=${CONTEGO_VM_TIMEOUT:-900}
while (($#)); do
  case "$1" in
    --arch) arch=$2; shift 2 ;;
    --mirror) mirrors+=(--mirror "$2"); shift 2 ;;
    --skip-code) skip_code=$2; shift 2 ;;
    --contego) contego=$2; shift 2 ;;
    --bench-client) bench_client=$2; shift 2 ;;
    --test-binary) test_binaries+=("$2"); shift 2 ;;
    --attack-binary) attack_binaries+=(--attack "$2"); shift 2 ;;
    --workdir) workdir=$2; shift 2 ;;
    --scenarios) scenarios=$2; shift 2 ;;
    --shell) shell=1; shift ;;
    --gtest-filter) gtest_filter=$2; shift 2 ;;
    --timeout) limit=$2; shift 2 ;;
    *) echo "run.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

fail() { echo "VM TEST BED FAILED: $*" >&2; exit 1; }
# A missing tool: a failure, or with --skip-code a skip that says why.
missing() {
  [[ -n "$skip_code" ]] || fail "$*"
  echo "VM TEST BED SKIPPED: $*"
  exit "$skip_code"
}

host_arch=$(dpkg --print-architecture)
case "$arch" in
  amd64) qemu_name=qemu-system-x86_64 qemu_pkg=qemu-system-x86 console=ttyS0 boot_opt="" ;;
  arm64) qemu_name=qemu-system-aarch64 qemu_pkg=qemu-system-arm console=ttyAMA0 boot_opt=" --cross-arm64" ;;
  *) fail "unknown architecture $arch (amd64 or arm64)" ;;
esac
qemu=$(command -v $qemu_name) ||
  missing "$qemu_name not found: run bash tools/bootstrap.sh$boot_opt (package $qemu_pkg)"
userland_args=()
if [[ "$arch" != "$host_arch" ]]; then
  for tool in aarch64-linux-gnu-gcc qemu-aarch64 mmdebstrap; do
    command -v $tool >/dev/null || missing "$tool not found: run bash tools/bootstrap.sh --cross-arm64"
  done
  [[ -d /usr/lib/linux-kbuild-6.1 ]] && compgen -G '/usr/src/linux-source-6.1.tar.*' >/dev/null ||
    missing "linux-source-6.1 or linux-kbuild-6.1 not installed: run bash tools/bootstrap.sh --cross-arm64"
fi
mkdir -p "$workdir"
if ((${#attack_binaries[@]} == 0)) && [[ "$arch" == "$host_arch" ]]; then
  for f in "$src"/build/dev/tests/intercept/attack_*; do
    [[ -x "$f" && -f "$f" ]] && attack_binaries+=(--attack "$f")
  done
fi

t_start=$(date +%s.%N)
kdir=$(bash "$here/fetch-kernel.sh" --arch "$arch") || fail "cannot get Debian's $arch kernel (see fetch-kernel's message above)"
if [[ "$arch" != "$host_arch" ]]; then
  userland=$(bash "$here/fetch-userland.sh" --arch "$arch") ||
    fail "cannot get Debian's $arch user space (see fetch-userland's message above)"
  userland_args=(--arch "$arch" --userland "$userland")
fi
t_kernel=$(date +%s.%N)
# contego.ko (docs/kernel-client.md) and the plain-I2C test adapter
# (tests/vm/kmod), built against the headers of exactly this kernel; without
# them the scenarios that need them report a skip.
if [[ -d "$kdir/headers" ]]; then
  headers=$kdir/headers/  # arm64: the headers the kernel cache keeps (fetch-kernel.sh)
else
  headers=/usr/src/linux-headers-$(cat "$kdir/version")
  # Another kernel of the archive (CONTEGO_VM_KERNEL): its headers are
  # unpacked, not installed (kernel/fetch-headers.sh).
  if [[ ! -f "$headers/Makefile" ]]; then
    headers=$(bash "$src/kernel/fetch-headers.sh" "linux-headers-$(cat "$kdir/version")") ||
      headers=/usr/src/linux-headers-$(cat "$kdir/version")
  fi
fi
# build_module NAME SCRIPT [OPTION]: prints the module's path, nothing when skipped
build_module() {
  local rc=0
  bash "$2" ${3:+"$3"} --arch "$arch" "$workdir/kmod" "$headers" >&2 || rc=$?
  case $rc in
    0) echo "$workdir/kmod/$1" ;;
    77) echo "run.sh: $1 not built (no headers for $(cat "$kdir/version")): its scenarios skip" >&2 ;;
    *) fail "building $1 failed ($2 exit $rc)" ;;
  esac
}
# --kunit: with the KUnit tests of its pure parts (scenario 66), which need
# Debian's linux-source for KUnit itself (kernel/kunit/unpack.sh).
kmod=$(build_module contego.ko "$src/kernel/build.sh" --kunit) || exit 1
plain_stub=$(build_module i2c-plain-stub.ko "$here/kmod/build.sh") || exit 1
# A statically linked copy of the bench client: no dynamic loader, so no
# preload can reach it; only the kernel client checks it (scenario 60).
# For arm64 Debian's cross gcc links it (libc6-dev-arm64-cross has libc.a).
static_cc=cc
[[ "$arch" == "$host_arch" ]] || static_cc=aarch64-linux-gnu-gcc
static_client=$workdir/i2c-write-loop-static
"$static_cc" -static -O2 -o "$static_client" "$here/bench/i2c_write_loop.c" ||
  fail "cannot link the static bench client with $static_cc (libc6-dev's libc.a)"
t_kmod=$(date +%s.%N)
host_tool=$src/build/dev/src/cli/contego  # runs here: makes the signed bundle
[[ -x "$host_tool" ]] || host_tool=
CONTEGO_STATIC_CLIENT=$static_client CONTEGO_KMOD=$kmod CONTEGO_PLAIN_STUB=$plain_stub \
  CONTEGO_HOST_TOOL=$host_tool bash "$here/build-initramfs.sh" \
  "${userland_args[@]}" "${mirrors[@]}" "${attack_binaries[@]}" "$workdir/initrd.cpio" \
  "$contego" "$kdir" "$bench_client" "${test_binaries[@]}" ||
  fail "cannot build the guest initramfs"
t_initrd=$(date +%s.%N)

accel_arch=$arch accel_kernel=$kdir/vmlinuz
. "$here/accel.sh"
append="console=$console quiet panic=-1 contego.scenarios=$scenarios contego.accel=$accel_name"
[[ -z "$gtest_filter" ]] || append+=" contego.gtest_filter=$gtest_filter"
[[ -z "${CONTEGO_VM_APPEND:-}" ]] || append+=" $CONTEGO_VM_APPEND"
qemu_args=("${machine[@]}" "${accel[@]}" -m 1024 -smp 2 -nographic -no-reboot -nic none
  -kernel "$kdir/vmlinuz" -initrd "$workdir/initrd.cpio")

if ((shell)); then
  echo "run.sh: booting $(cat "$kdir/version") ($accel_name) to a shell; Ctrl-A X quits QEMU" >&2
  exec "$qemu" "${qemu_args[@]}" -append "$append contego.shell=1"
fi

echo "run.sh: booting $(cat "$kdir/version") under $accel_name, scenarios: $scenarios, limit ${limit}s" >&2
log=$workdir/console.log
set +e
# stdin from /dev/null: QEMU's -nographic would otherwise take the CI's
# terminal; the console goes to the log and, live, to our stdout.
timeout -k 10 "$limit" "$qemu" "${qemu_args[@]}" -append "$append" </dev/null 2>&1 |
  tr -d '\r' | sed -u 's/\x1b\[[0-9;?]*[a-zA-Z]//g' | tee "$log"
qemu_rc=${PIPESTATUS[0]}
set -e
t_end=$(date +%s.%N)

echo
echo "==== test bed summary (console: $log) ===="
awk -v a="$t_start" -v b="$t_kernel" -v c="$t_initrd" -v d="$t_end" -v size="$(du -h "$workdir/initrd.cpio" | cut -f1)" \
  -v k="$t_kmod" -v accel="$accel_name" 'BEGIN { printf "kernel fetch %.1fs, contego.ko %.1fs, initramfs %.1fs (%s), boot+scenarios %.1fs (%s)\n", b - a, k - b, c - k, size, d - c, accel }'
grep -aE '^VM-(BOOTED|RESULT|DONE)' "$log" || true
grep -aE '^VM-CHECK (FAIL|SKIP)' "$log" || true
((qemu_rc != 124 && qemu_rc != 137)) || fail "QEMU killed after ${limit}s: the guest hung (see $log)"
grep -aq '^VM-BOOTED' "$log" || fail "the guest never came up (QEMU exit $qemu_rc; see $log)"
grep -aq '^VM-DONE' "$log" || fail "the guest did not finish its scenarios (QEMU exit $qemu_rc; see $log)"
! grep -aq '^VM-RESULT FAIL' "$log" || fail "$(grep -ac '^VM-RESULT FAIL' "$log") scenario(s) failed: $(grep -a '^VM-RESULT FAIL' "$log" | awk '{print $3}' | tr '\n' ' ')"
grep -aq '^VM-RESULT PASS' "$log" || fail "no scenario ran"
echo "VM TEST BED PASSED"
