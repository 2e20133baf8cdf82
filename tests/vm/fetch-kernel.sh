#!/usr/bin/env bash
# Fetches Debian 12's own kernel for amd64 or arm64 (the package
# linux-image-ARCH points at today) and unpacks it, without installing
# anything on the host, into a cache outside the clone, keyed by the kernel
# version. A second run finds the unpacked tree and does no network I/O.
#
# Prints the cache directory of that kernel on stdout; it holds
#   vmlinuz            the kernel image
#   modules/           i2c-stub.ko and i2c-dev.ko, decompressed if shipped compressed
#   version            the kernel release (e.g. 6.1.0-NN-amd64)
#   headers/           arm64 only: the kernel's linux-headers (unpacked, with the
#                      host's kbuild tools), for building contego.ko
#
# Debian's arm64 kernel is built without i2c-stub: for arm64 the module is
# cross-built here from Debian's own kernel source (linux-source-6.1,
# drivers/i2c/i2c-stub.c) against the kernel's linux-headers-*-arm64 (fetched
# like the image; their scripts are the host's linux-kbuild-6.1), with
# Debian's aarch64-linux-gnu-gcc. bootstrap.sh --cross-arm64 installs those.
#
# Usage: tests/vm/fetch-kernel.sh [--arch amd64|arm64]   (default amd64)
# Env:   CONTEGO_VM_CACHE   cache root (default ${XDG_CACHE_HOME:-$HOME/.cache}/contego-vm)
#        CONTEGO_VM_KERNEL  another kernel package of the archive instead
#                           (amd64, e.g. linux-image-6.12.117+deb12-amd64)
set -euo pipefail

die() { echo "fetch-kernel: $*" >&2; exit 1; }

arch=amd64
if [[ "${1:-}" == --arch ]]; then arch=$2; fi
case "$arch" in amd64 | arm64) ;; *) die "unknown architecture $arch (amd64 or arm64)" ;; esac
# On an amd64 host the arm64 packages are foreign: name them PKG:arm64.
qual=""
[[ "$arch" == "$(dpkg --print-architecture)" ]] || qual=":$arch"

cache_root=${CONTEGO_VM_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/contego-vm}

command -v apt-cache >/dev/null || die "apt-cache not found: this needs a Debian (12) host"
# The ABI package moves with security updates (linux-image-6.1.0-NN-ARCH):
# ask the metapackage which one it is today instead of naming it.
pkg=$(apt-cache depends "linux-image-$arch$qual" 2>/dev/null |
  awk '/Depends: linux-image-[0-9]/ { sub(/:.*/, "", $2); print $2; exit }')
if [[ -n "${CONTEGO_VM_KERNEL:-}" ]]; then
  [[ "$arch" == amd64 ]] || die "CONTEGO_VM_KERNEL is for amd64 (arm64 builds its i2c-stub from 6.1's source)"
  pkg=$CONTEGO_VM_KERNEL
fi
[[ -n "$pkg" ]] || die "cannot resolve the kernel package behind linux-image-$arch (apt-cache depends linux-image-$arch$qual names none; run apt-get update${qual:+, dpkg --add-architecture $arch}?)"
release=${pkg#linux-image-}
# The package version (e.g. 6.1.123-1) changes on a rebuild of the same ABI;
# key the cache by both so a rebuilt kernel is fetched again.
version=$(apt-cache policy "$pkg$qual" | awk '/Candidate:/ { print $2 }')
[[ -n "$version" && "$version" != "(none)" ]] || die "no installable candidate for $pkg$qual"
dir="$cache_root/$release/$version"

# An arm64 cache also keeps the kernel's headers (for contego.ko); one made
# before it did is fetched again.
if [[ -f "$dir/.complete" && ( "$arch" != arm64 || -f "$dir/headers/Makefile" ) ]]; then
  echo "$dir"
  exit 0
fi

echo "fetch-kernel: downloading $pkg $version into $dir" >&2
mkdir -p "$dir"
tmp=$(mktemp -d "$dir/.tmp.XXXXXX")
chmod 755 "$tmp" # apt-get download drops to the _apt user, which must reach it
trap 'rm -rf "$tmp"' EXIT
# apt-get download writes to the current directory and needs no root.
(cd "$tmp" && apt-get download -q "$pkg$qual=$version" >&2) ||
  die "apt-get download $pkg$qual=$version failed (network to the Debian archive?)"
deb=$(ls "$tmp"/*.deb)
dpkg -x "$deb" "$tmp/root"

vmlinuz=$(ls "$tmp"/root/boot/vmlinuz-* 2>/dev/null | head -n1)
[[ -n "$vmlinuz" ]] || die "$deb holds no boot/vmlinuz-*"
moddir="$tmp/root/lib/modules/$release"
[[ -d "$moddir" ]] || die "$deb holds no lib/modules/$release"

mkdir -p "$tmp/modules"
shipped=(i2c-stub i2c-dev)
if [[ "$arch" == arm64 ]]; then
  shipped=(i2c-dev)
  # In the cache, not in $tmp: the headers it unpacks stay (contego.ko is
  # built against them: kernel/build.sh with ARCH=arm64) and name their own
  # absolute path, so they are unpacked where they are kept.
  rm -rf "$dir/kbuild"
  bash "$(dirname "$0")/build-i2c-stub.sh" "$dir/kbuild" "$pkg" "$version" "$release" "$tmp/modules/i2c-stub.ko" >&2 ||
    die "cannot build i2c-stub.ko for $release (see above)"
  rm -rf "$dir/kbuild/stub-build/debs" "$dir/kbuild/stub-build/module"
  ln -sfn "kbuild/stub-build/root/usr/src/linux-headers-$release" "$dir/headers"
fi
# Debian 12 ships plain .ko files; later kernels may compress them (.ko.xz,
# .ko.zst). busybox insmod wants plain ones, so decompress on the host.
for m in "${shipped[@]}"; do
  f=$(find "$moddir" -name "$m.ko" -o -name "$m.ko.xz" -o -name "$m.ko.zst" -o -name "$m.ko.gz" | head -n1)
  [[ -n "$f" ]] || die "$m.ko not in $deb (kernel built without it?)"
  case "$f" in
    *.ko) cp "$f" "$tmp/modules/$m.ko" ;;
    *.xz) xz -dc "$f" >"$tmp/modules/$m.ko" ;;
    *.zst) zstd -qdc "$f" >"$tmp/modules/$m.ko" ;;
    *.gz) gzip -dc "$f" >"$tmp/modules/$m.ko" ;;
  esac
done

cp "$vmlinuz" "$dir/vmlinuz"
rm -rf "$dir/modules"
mv "$tmp/modules" "$dir/modules"
echo "$release" >"$dir/version"
# Only the kernel and two modules are kept (about 8 MB); the .deb and the
# unpacked tree (about 400 MB) are dropped.
touch "$dir/.complete"
echo "$dir"
