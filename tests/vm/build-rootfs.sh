#!/usr/bin/env bash
# The booted guest's root file system (docs/testbed.md, "The booted Debian
# guest"): Debian 12 made by mmdebstrap from Debian's archive, with systemd as
# PID 1, udev, kmod, i2c-tools, python3-smbus2, the packages each PACKAGE.deb
# depends on and recommends (so that `apt-get install ./PACKAGE.deb` in the
# guest needs no network; for a package that depends on dkms also the
# kernel's linux-headers, which the README installs beside it), and the i2c-stub and i2c-dev modules of the test
# bed's kernel (fetch-kernel.sh) under lib/modules, depmod'ed. Packed as an
# uncompressed cpio archive whose /init is systemd: the kernel unpacks it as
# its root file system, no disk image needed.
#
# Cached outside the clone beside the kernel, keyed by the architecture, the
# package list and the kernel release: a rerun with the same dependencies
# does no network I/O and builds nothing. Prints the cpio's path on stdout.
#
# --arch arm64 makes an arm64 Debian on this amd64 host: mmdebstrap runs its
# maintainer scripts under qemu-user-static, registered with binfmt_misc
# (tools/bootstrap.sh --cross-arm64; registered here if it is not yet).
#
# Usage: tests/vm/build-rootfs.sh [--arch amd64|arm64] KERNEL_DIR PACKAGE.deb [PACKAGE.deb...]
# Env:   CONTEGO_VM_CACHE   cache root (as fetch-kernel.sh)
set -euo pipefail

die() { echo "build-rootfs: $*" >&2; exit 1; }
arch=$(dpkg --print-architecture)
if [[ ${1:-} == --arch ]]; then
  arch=$2
  shift 2
fi
case $arch in
  amd64) console=ttyS0 ;;
  arm64) console=ttyAMA0 ;;
  *) die "unknown architecture $arch (amd64 or arm64)" ;;
esac
(($# >= 2)) || die "usage: build-rootfs.sh [--arch amd64|arm64] KERNEL_DIR PACKAGE.deb [PACKAGE.deb...]"
kdir=$1
shift
[[ -f $kdir/vmlinuz && -f $kdir/version ]] || die "$kdir is not a fetch-kernel.sh directory"
for deb in "$@"; do [[ -f $deb ]] || die "no package $deb"; done
cache_root=${CONTEGO_VM_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/contego-vm}
release=$(cat "$kdir/version")

# The guest's packages: the test bed's tools, sudo and adduser (the README's
# Install section uses them, as a Raspberry Pi OS system has them), and the
# packages' own Depends and Recommends (first of each alternative, versions
# dropped: bookworm's are the ones they were built against; a package of the
# set itself, as contego-dkms recommends contego, comes from its .deb).
# The fleet's own tools the scenario ships the monitor's output with:
# node_exporter (the metrics file), curl, systemd-journal-remote.
base=(systemd-sysv udev kmod dbus i2c-tools python3-smbus2 sudo adduser apt
  prometheus-node-exporter curl systemd-journal-remote)
deps=$(for deb in "$@"; do dpkg-deb -f "$deb" Depends Recommends; done | sed 's/^[A-Za-z-]*: //' |
  tr ',' '\n' | sed 's/|.*//; s/(.*)//; s/:any//; s/^ *//; s/ *$//' | grep -v '^$' || true)
own=$(for deb in "$@"; do dpkg-deb -f "$deb" Package; done)
deps=$(grep -vxF -f <(echo "$own") <<<"$deps" || true)
grep -qx dkms <<<"$deps" && deps+=$'\n'"linux-headers-$release"
mapfile -t pkgs < <(printf '%s\n' "${base[@]}" $deps | sort -u)
key=$(printf '%s\n' bookworm "$release" "${pkgs[@]}" | sha256sum | cut -c1-16)
# amd64's key as it was (its caches stay valid); another architecture's apart.
[[ $arch == "$(dpkg --print-architecture)" ]] ||
  key=$(printf '%s\n' "$arch" "$key" | sha256sum | cut -c1-16)
dir=$cache_root/rootfs/$key
if [[ -f $dir/.complete ]]; then
  echo "$dir/rootfs.cpio"
  exit 0
fi

command -v mmdebstrap >/dev/null || die "mmdebstrap not found: run bash tools/bootstrap.sh"
command -v cpio >/dev/null || die "cpio not found: run bash tools/bootstrap.sh"
mode=root
[[ $(id -u) == 0 ]] || mode=unshare # without root: user namespaces
if [[ $arch != "$(dpkg --print-architecture)" ]]; then
  # A foreign architecture's maintainer scripts run under QEMU's user-mode
  # emulator. binfmt-support registers it at boot; where its service did not
  # run (a container, a fresh install without a reboot) it is registered now.
  qarch=aarch64
  if [[ ! -e /proc/sys/fs/binfmt_misc/qemu-$qarch ]]; then
    command -v update-binfmts >/dev/null && [[ -e /usr/share/binfmts/qemu-$qarch ]] ||
      die "qemu-user-static and binfmt-support not installed (bash tools/bootstrap.sh --cross-arm64)"
    [[ $(id -u) == 0 ]] || die "QEMU's $qarch emulator is not registered with binfmt_misc (as root: update-binfmts --enable qemu-$qarch)"
    update-binfmts --enable "qemu-$qarch" >&2 ||
      die "cannot register QEMU's $qarch emulator with binfmt_misc (update-binfmts --enable qemu-$qarch)"
  fi
  grep -qx enabled "/proc/sys/fs/binfmt_misc/qemu-$qarch" 2>/dev/null ||
    die "QEMU's $qarch emulator is registered but disabled in binfmt_misc (update-binfmts --enable qemu-$qarch)"
fi
echo "build-rootfs: mmdebstrap bookworm $arch (${pkgs[*]}) into $dir" >&2
mkdir -p "$dir"
tmp=$(mktemp -d "$dir/.tmp.XXXXXX")
# mmdebstrap mounts /proc, /sys and parts of the host's /dev (a bind mount of
# /dev/shm) in the tree; a run that fails can leave them there. Unmount what
# is left, and never let the removal cross into another file system.
cleanup() {
  awk -v t="$tmp/" 'index($5, t) == 1 { print $5 }' /proc/self/mountinfo | sort -r |
    while read -r m; do umount -l "$m" 2>/dev/null || true; done
  rm -rf --one-file-system "$tmp"
}
trap cleanup EXIT
chmod 755 "$tmp"
root=$tmp/root
mkdir "$root"
# Keep apt's package lists: `apt-get install ./x.deb` resolves the package's
# dependencies against them (all installed, so nothing is downloaded).
mmdebstrap --mode=$mode --variant=minbase --architectures="$arch" --skip=cleanup/apt/lists \
  --include="$(
    IFS=,
    echo "${pkgs[*]}"
  )" bookworm "$root" >&2 || die "mmdebstrap failed (network to Debian's archive?)"

# The kernel's modules where modprobe looks for them.
moddir=$root/lib/modules/$release/kernel/drivers/i2c
mkdir -p "$moddir/busses"
cp "$kdir/modules/i2c-dev.ko" "$moddir/"
cp "$kdir/modules/i2c-stub.ko" "$moddir/busses/"
depmod -b "$root" "$release" 2>/dev/null || chroot "$root" depmod "$release" ||
  die "depmod failed"

# systemd as the initramfs's /init; a root file system in memory, no fstab.
ln -sf /lib/systemd/systemd "$root/init"
: >"$root/etc/fstab"
# The serial console is the scenario's, not a login prompt's.
ln -sf /dev/null "$root/etc/systemd/system/serial-getty@$console.service"
# apt asks before it installs; the scenario answers yes, as a person would.
echo 'APT::Get::Assume-Yes "true";' >"$root/etc/apt/apt.conf.d/90assume-yes"
rm -rf "$root/var/cache/apt/archives/"*.deb "$root/usr/share/doc" "$root/usr/share/man" \
  "$root/usr/share/locale"

(cd "$root" && find . -print0 | LC_ALL=C sort -z | cpio --null -o -H newc --quiet) >"$tmp/rootfs.cpio" ||
  die "cpio failed"
mv "$tmp/rootfs.cpio" "$dir/rootfs.cpio"
printf '%s\n' "${pkgs[@]}" >"$dir/packages"
touch "$dir/.complete"
echo "$dir/rootfs.cpio"
