#!/usr/bin/env bash
# Builds contego.ko (docs/kernel-client.md) with Kbuild against Debian's
# linux-headers of the test bed's kernel: the one linux-image-amd64 points at
# (resolved as tests/vm/fetch-kernel.sh does), or KDIR if given.
#
# Usage: kernel/build.sh [--arch amd64|arm64] OUT_DIR [KDIR]
#   OUT_DIR receives contego.ko (the Kbuild tree is built in OUT_DIR/kbuild).
#   --arch arm64 on an amd64 host cross-builds with Debian's
#   aarch64-linux-gnu-gcc/g++ against arm64 headers, which KDIR must name
#   (the arm64 test bed's kernel cache keeps them: tests/vm/fetch-kernel.sh).
# Exit 77 (skip) when the headers are not installed (bash tools/bootstrap.sh).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/.." && pwd)
arch=$(dpkg --print-architecture 2>/dev/null || echo amd64)
if [[ "${1:-}" == --arch ]]; then
  arch=${2:?--arch needs amd64 or arm64}
  shift 2
fi
cross=()
if [[ "$arch" != "$(dpkg --print-architecture 2>/dev/null || echo amd64)" ]]; then
  case "$arch" in
    arm64) cross=(ARCH=arm64 CROSS_COMPILE=aarch64-linux-gnu-) ;;
    *) echo "kernel/build.sh: cannot cross-build for $arch (arm64 only)" >&2; exit 2 ;;
  esac
  command -v aarch64-linux-gnu-g++ >/dev/null || {
    echo "kernel/build.sh: SKIP: no aarch64-linux-gnu-g++ (bash tools/bootstrap.sh --cross-arm64)" >&2
    exit 77
  }
  [[ -n "${2:-}" ]] || { echo "kernel/build.sh: SKIP: --arch $arch needs KDIR (arm64 headers)" >&2; exit 77; }
fi
out=${1:?usage: build.sh [--arch amd64|arm64] OUT_DIR [KDIR]}
kdir=${2:-}
if [[ -z "$kdir" ]]; then
  pkg=$(apt-cache depends linux-image-amd64 2>/dev/null |
    awk '/Depends: linux-image-[0-9]/ { print $2; exit }')
  [[ -n "$pkg" ]] || { echo "kernel/build.sh: cannot resolve linux-image-amd64's kernel" >&2; exit 77; }
  kdir=/usr/src/linux-headers-${pkg#linux-image-}
fi
if [[ ! -f "$kdir/Makefile" ]]; then
  echo "kernel/build.sh: SKIP: no kernel headers at $kdir (bash tools/bootstrap.sh installs them)" >&2
  exit 77
fi
mkdir -p "$out/kbuild"
out=$(cd "$out" && pwd)
kdir=$(cd "$kdir" && pwd -P)
# Kbuild builds in the module's directory: a copy, so the source tree stays clean.
cp "$here"/Kbuild "$here"/contego_main.c "$here"/contego_kmod.h "$out/kbuild/"
mkdir -p "$out/kbuild/shim"
cp "$here"/shim/*.h "$out/kbuild/shim/"
make -s -C "$kdir" M="$out/kbuild" CONTEGO_SRC="$src" "${cross[@]}" modules
cp "$out/kbuild/contego.ko" "$out/contego.ko"
echo "kernel/build.sh: $out/contego.ko ($(basename "$kdir"))" >&2
