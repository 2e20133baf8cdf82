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
# Cached outside the clone beside the kernel, keyed by the package list and
# the kernel release: a rerun with the same dependencies does no network I/O
# and builds nothing. Prints the cpio's path on stdout.
#
# Usage: tests/vm/build-rootfs.sh KERNEL_DIR PACKAGE.deb [PACKAGE.deb...]
# Env:   CONTEGO_VM_CACHE   cache root (as fetch-kernel.sh)
set -euo pipefail

die() { echo "build-rootfs: $*" >&2; exit 1; }
(($# >= 2)) || die "usage: build-rootfs.sh KERNEL_DIR PACKAGE.deb [PACKAGE.deb...]"
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
dir=$cache_root/rootfs/$key
if [[ -f $dir/.complete ]]; then
  echo "$dir/rootfs.cpio"
  exit 0
fi

command -v mmdebstrap >/dev/null || die "mmdebstrap not found: run bash tools/bootstrap.sh"
command -v cpio >/dev/null || die "cpio not found: run bash tools/bootstrap.sh"
mode=root
[[ $(id -u) == 0 ]] || mode=unshare # without root: user namespaces
echo "build-rootfs: mmdebstrap bookworm (${pkgs[*]}) into $dir" >&2
mkdir -p "$dir"
tmp=$(mktemp -d "$dir/.tmp.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
chmod 755 "$tmp"
root=$tmp/root
mkdir "$root"
# Keep apt's package lists: `apt-get install ./x.deb` resolves the package's
# dependencies against them (all installed, so nothing is downloaded).
mmdebstrap --mode=$mode --variant=minbase --skip=cleanup/apt/lists \
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
ln -sf /dev/null "$root/etc/systemd/system/serial-getty@ttyS0.service"
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
