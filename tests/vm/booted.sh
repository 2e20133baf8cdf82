#!/usr/bin/env bash
# The booted Debian guest, host side (docs/testbed.md): Debian 12 with systemd
# as PID 1 (build-rootfs.sh, cached), Debian's kernel (fetch-kernel.sh,
# cached), the package under test and the README's "Install" commands
# (extracted here, so that the guest runs what the README says), booted in
# QEMU (KVM when it works here, TCG otherwise: accel.sh). With --arch arm64 the
# guest is an arm64 Debian on Debian's arm64 kernel in qemu-system-aarch64
# (TCG), the package the arm64 one; the scenario is the same. The guest's scenario
# (booted/scenario.sh) installs, uses, stops, restarts, removes and purges
# the package and prints one line per check; this script judges them. With
# contego-dkms it also runs the README's "Install the kernel client" commands:
# DKMS builds contego.ko in the guest, against its kernel, and the module
# checks the program in i2c-dev's place.
#
# Usage: tests/vm/booted.sh [--arch amd64|arm64] [--deb PATH] [--dkms-deb PATH] [--workdir DIR]
#                           [--timeout SECONDS]
#   --arch      the guest's architecture (default amd64)
#   --deb       the package (default: $CONTEGO_DEB for amd64, tools/test.sh sets
#               it after its package stage; $CONTEGO_ARM64_DEB for arm64)
#   --dkms-deb  contego-dkms (default: $CONTEGO_DKMS_DEB); without it the
#               guest reports the kernel client's part as skipped
# Exit 77 (CTest: skipped) with the reason when there is no package, no
# QEMU, or Debian's kernel or archive cannot be reached (for arm64 also
# without qemu-user-static registered with binfmt_misc: bootstrap.sh --cross-arm64).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
arch=amd64 deb="" workdir=""
dkms_deb=${CONTEGO_DKMS_DEB:-}
limit=${CONTEGO_VM_TIMEOUT:-}
while (($#)); do
  case "$1" in
    --arch) arch=$2; shift 2 ;;
    --deb) deb=$2; shift 2 ;;
    --dkms-deb) dkms_deb=$2; shift 2 ;;
    --workdir) workdir=$2; shift 2 ;;
    --timeout) limit=$2; shift 2 ;;
    *) echo "booted.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

skip() { echo "SKIPPED: $*"; exit 77; }
fail() { echo "BOOTED GUEST FAILED: $*" >&2; exit 1; }

# Per architecture: the package's variable, QEMU, the serial console, what
# installs the tools, the guest's time limit (TCG's emulated arm64 is several
# times slower), and how the host runs the package's own contego.
case $arch in
  amd64)
    deb_var=CONTEGO_DEB qemu_name=qemu-system-x86_64 console=ttyS0 boot=tools/bootstrap.sh
    deb_hint="tools/test.sh sets it after building the package"
    : "${limit:=1000}"
    run_pkg=()
    ;;
  arm64)
    deb_var=CONTEGO_ARM64_DEB qemu_name=qemu-system-aarch64 console=ttyAMA0
    boot="tools/bootstrap.sh --cross-arm64"
    deb_hint="CONTEGO_BOOTED_ARM64=1 bash tools/test.sh sets it after building the package"
    : "${limit:=3600}"
    run_pkg=(qemu-aarch64)
    ;;
  *) fail "unknown architecture $arch (amd64 or arm64)" ;;
esac
[[ -n $deb ]] || deb=${!deb_var:-}
[[ -n $workdir ]] || workdir=$src/build/dev/tests/vm/booted$([[ $arch == amd64 ]] || echo "-$arch")
[[ -n $deb ]] || skip "no package: give --deb or $deb_var ($deb_hint)"
[[ -f $deb ]] || skip "no package at $deb (bash tools/package.sh --arch $arch builds it)"
[[ $(dpkg-deb -f "$deb" Architecture) == "$arch" ]] || skip "$deb is not an $arch package"
qemu=$(command -v $qemu_name) || skip "$qemu_name not found (bash $boot)"
command -v cpio >/dev/null || skip "cpio not found (bash $boot)"
debs=("$deb")
if [[ -n $dkms_deb ]]; then
  [[ -f $dkms_deb ]] || fail "no contego-dkms package at $dkms_deb"
  debs+=("$dkms_deb")
fi

mkdir -p "$workdir"
t0=$SECONDS
kdir=$(bash "$here/fetch-kernel.sh" --arch "$arch") ||
  skip "cannot get Debian's $arch kernel (fetch-kernel.sh's message above)"
t1=$SECONDS
rootfs=$(bash "$here/build-rootfs.sh" --arch "$arch" "$kdir" "${debs[@]}") ||
  skip "cannot build the Debian root file system (build-rootfs.sh's message above)"
t2=$SECONDS

# What the guest gets on top of the cached root file system, as a second
# cpio archive (the kernel unpacks both, the later one over the first): the
# package, the scenario, the README's commands and the unit that runs them.
extra=$workdir/extra
rm -rf "$extra"
mkdir -p "$extra/vm/pkg" "$extra/vm/readme" "$extra/vm/readme-kmod" \
  "$extra/etc/systemd/system/multi-user.target.wants"
# A host name the guest resolves (sudo asks), as on any installed system.
printf '127.0.0.1 localhost\n127.0.1.1 guest\n' >"$extra/etc/hosts"
echo guest >"$extra/etc/hostname"
cp "${debs[@]}" "$extra/vm/pkg/"
cp "$here/booted/scenario.sh" "$extra/vm/"
# Signed bundles for the guest's --require-signed checks: compiled by the
# package's own contego, signed with a throwaway key by the real minisign;
# the guest only verifies. Without minisign the scenario says it skips them.
# An arm64 package's contego runs here under QEMU's user-mode emulator.
if command -v minisign >/dev/null && { ((${#run_pkg[@]} == 0)) || command -v "${run_pkg[0]}" >/dev/null; }; then
  signing=$(mktemp -d)
  dpkg-deb -x "$deb" "$signing/root"
  mkdir -p "$extra/vm/signed"
  minisign -G -W -p "$extra/vm/signed/robot.pub" -s "$signing/robot.key" >/dev/null
  (cd "$src" && "${run_pkg[@]}" "$signing/root/usr/bin/contego" check policies/arm.policy \
    --emit-bundle "$extra/vm/signed/arm.bundle" >/dev/null 2>&1) || fail "contego check --emit-bundle"
  minisign -S -s "$signing/robot.key" -m "$extra/vm/signed/arm.bundle" -t "booted guest arm" >/dev/null
  cp "$extra/vm/signed/arm.bundle" "$extra/vm/signed/unsigned.bundle"
  sed 's/"sessions": 1/"sessions": 9/' "$extra/vm/signed/arm.bundle" >"$extra/vm/signed/changed.bundle"
  cp "$extra/vm/signed/arm.bundle.minisig" "$extra/vm/signed/changed.bundle.minisig"
  rm -rf "$signing"
fi
# The ```sh blocks of a README section, one file each, in order: "## Install"
# and, with contego-dkms, "## Install the kernel client (contego.ko)".
# `bash tools/package.sh` builds the packages on the build machine: the host
# has just done that; every other line runs in the guest.
readme_blocks() {
  awk -v dir="$2" -v section="## $1" '
    /^## / { inside = ($0 == section) }
    inside && /^```sh$/ { n++; file = sprintf("%s/%d.sh", dir, n); lines = 0; inblock = 1; next }
    inblock && /^```$/ { inblock = 0; if (!lines) n--; next }
    inblock && $0 !~ /^bash tools\/package\.sh/ { print > file; lines++ }
  ' "$src/README.md"
}
readme_blocks Install "$extra/vm/readme"
if [[ -n $dkms_deb ]]; then
  readme_blocks "Install the kernel client (contego.ko)" "$extra/vm/readme-kmod"
  (($(ls "$extra/vm/readme-kmod" | wc -l) >= 2)) ||
    fail "README.md's \"Install the kernel client (contego.ko)\" section has no commands to run"
fi
nblocks=$(ls "$extra/vm/readme" | wc -l)
((nblocks >= 2)) || fail "README.md's Install section has no commands to run (found $nblocks blocks)"
cat >"$extra/etc/systemd/system/guest-scenario.service" <<EOF
[Unit]
Description=the booted-guest scenario (tests/vm/booted)
After=multi-user.target
[Service]
Type=oneshot
ExecStart=/bin/bash /vm/scenario.sh
StandardOutput=tty
StandardError=inherit
TTYPath=/dev/$console
TimeoutStartSec=infinity
SuccessAction=poweroff-force
FailureAction=poweroff-force
EOF
ln -sf ../guest-scenario.service "$extra/etc/systemd/system/multi-user.target.wants/"
(cd "$extra" && find . | LC_ALL=C sort | cpio -o -H newc --quiet -R 0:0) >"$workdir/extra.cpio"
cat "$rootfs" "$workdir/extra.cpio" >"$workdir/initrd.cpio"
t3=$SECONDS

accel_arch=$arch accel_kernel=$kdir/vmlinuz
. "$here/accel.sh"
log=$workdir/console.log
echo "booted.sh: $arch, $(cat "$kdir/version") under $accel_name, $(basename -a "${debs[@]}" | paste -sd' '), limit ${limit}s" >&2
set +e
timeout -k 10 "$limit" "$qemu" "${machine[@]}" "${accel[@]}" -m 3072 -smp 2 -nographic -no-reboot -nic none \
  -kernel "$kdir/vmlinuz" -initrd "$workdir/initrd.cpio" \
  -append "console=$console quiet loglevel=3 panic=-1 systemd.show_status=false" </dev/null 2>&1 |
  tr -d '\r' | sed -u 's/\x1b\[[0-9;?]*[a-zA-Z]//g; s/\x1b[c78]//g' >"$log"
qemu_rc=${PIPESTATUS[0]}
set -e
t4=$SECONDS
rm -f "$workdir/initrd.cpio"

echo "==== booted Debian $arch guest (console: $log) ===="
grep -aE '^VM-(BOOTED|RESULT)' "$log" || true
echo "kernel $((t1 - t0))s, root file system $((t2 - t1))s ($(du -h "$rootfs" | cut -f1)), initramfs $((t3 - t2))s, boot+scenario $((t4 - t3))s ($accel_name)"
grep -aE '^VM-CHECK' "$log" || true
((qemu_rc != 124 && qemu_rc != 137)) || fail "QEMU killed after ${limit}s: the guest hung (see $log)"
grep -aq '^VM-BOOTED' "$log" || fail "the guest never ran its scenario (QEMU exit $qemu_rc; see $log)"
grep -aq '^VM-DONE' "$log" || fail "the scenario did not finish (QEMU exit $qemu_rc; see $log)"
grep -aq '^VM-RESULT PASS' "$log" || { tail -n 120 "$log"; fail "$(grep -a '^VM-RESULT' "$log")"; }
echo "BOOTED GUEST PASSED"
