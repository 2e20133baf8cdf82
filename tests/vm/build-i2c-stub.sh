#!/usr/bin/env bash
# Cross-builds i2c-stub.ko for Debian's arm64 kernel, which ships without it
# (# CONFIG_I2C_STUB is not set). Called by fetch-kernel.sh --arch arm64,
# whose cache keeps the result; nothing is installed on the host.
#   source   drivers/i2c/i2c-stub.c of Debian's own kernel source, the
#            linux-source-6.1 package (/usr/src/linux-source-6.1.tar.xz)
#   headers  linux-headers-RELEASE (arm64) and its -common package, fetched
#            with apt-get download at the kernel's version; their scripts/
#            and tools/ are the host's linux-kbuild-6.1 (host binaries)
#   compiler Debian's aarch64-linux-gnu-gcc
#
# Usage: build-i2c-stub.sh WORKDIR IMAGE_PACKAGE VERSION RELEASE OUT.ko
set -euo pipefail

die() { echo "build-i2c-stub: $*" >&2; exit 1; }
(($# == 5)) || die "usage: build-i2c-stub.sh WORKDIR IMAGE_PACKAGE VERSION RELEASE OUT.ko"
work=$1/stub-build pkg=$2 version=$3 release=$4 out=$5

tarball=$(ls /usr/src/linux-source-6.1.tar.* 2>/dev/null | head -n1)
[[ -n "$tarball" ]] || die "no /usr/src/linux-source-6.1.tar.* (bash tools/bootstrap.sh --cross-arm64 installs linux-source-6.1)"
command -v aarch64-linux-gnu-gcc >/dev/null ||
  die "aarch64-linux-gnu-gcc missing (bash tools/bootstrap.sh --cross-arm64)"
[[ -d /usr/lib/linux-kbuild-6.1/scripts ]] ||
  die "no /usr/lib/linux-kbuild-6.1 (bash tools/bootstrap.sh --cross-arm64 installs linux-kbuild-6.1)"
src_version=$(dpkg-query -W -f='${Version}' linux-source-6.1)
# The module's version magic and symbol CRCs come from the headers, so a
# source a security update older or newer still loads; say so all the same.
[[ "$src_version" == "$version" ]] ||
  echo "build-i2c-stub: note: linux-source-6.1 is $src_version, the kernel $version (apt-get upgrade?)" >&2

mkdir -p "$work/debs" "$work/root" "$work/module"
chmod 755 "$work" "$work/debs" # apt-get download drops to the _apt user
headers=linux-headers-$release
(cd "$work/debs" && apt-get download -q "$headers:arm64=$version" \
  "${headers%-arm64}-common=$version" >&2) ||
  die "apt-get download $headers=$version failed (network to the Debian archive?)"
for deb in "$work"/debs/*.deb; do dpkg -x "$deb" "$work/root"; done
hdir=$work/root/usr/src/$headers
[[ -f "$hdir/Makefile" ]] || die "$headers holds no usr/src/$headers/Makefile"
# The headers name their other half and the kbuild tools by absolute paths
# (/usr/src/...-common, /usr/lib/linux-kbuild-6.1): point them at the
# unpacked copy and at the host's kbuild.
sed -i "s,^include /usr/src/,include $work/root/usr/src/," "$hdir/Makefile"
kbuild=$(readlink "$hdir/scripts")
kbuild=${kbuild%/scripts}
kbuild=/usr/lib/${kbuild##*/}
[[ -d "$kbuild" ]] || die "the headers want $kbuild, which is not installed (apt-get install ${kbuild##*/})"
mkdir -p "$work/root/usr/lib"
ln -sfn "$kbuild" "$work/root/usr/lib/${kbuild##*/}"

tar -xf "$tarball" -C "$work" --strip-components=3 linux-source-6.1/drivers/i2c/i2c-stub.c ||
  die "$tarball holds no drivers/i2c/i2c-stub.c"
mv "$work/i2c-stub.c" "$work/module/"
echo 'obj-m := i2c-stub.o' >"$work/module/Kbuild"
make -s -C "$hdir" M="$work/module" ARCH=arm64 CROSS_COMPILE=aarch64-linux-gnu- modules
[[ -f "$work/module/i2c-stub.ko" ]] || die "kbuild produced no i2c-stub.ko"
cp "$work/module/i2c-stub.ko" "$out"
echo "build-i2c-stub: built i2c-stub.ko for $release from linux-source-6.1 $src_version" >&2
