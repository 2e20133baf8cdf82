#!/usr/bin/env bash
# Builds contego.ko (docs/kernel-client.md) with Kbuild against Debian's
# linux-headers of the test bed's kernel: the one linux-image-amd64 points at
# (resolved as tests/vm/fetch-kernel.sh does), or KDIR if given.
#
# Usage: kernel/build.sh OUT_DIR [KDIR]
#   OUT_DIR receives contego.ko (the Kbuild tree is built in OUT_DIR/kbuild).
# Exit 77 (skip) when the headers are not installed (bash tools/bootstrap.sh).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/.." && pwd)
out=${1:?usage: build.sh OUT_DIR [KDIR]}
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
# Kbuild builds in the module's directory: a copy, so the source tree stays clean.
cp "$here"/Kbuild "$here"/contego_main.c "$here"/contego_kmod.h "$out/kbuild/"
mkdir -p "$out/kbuild/shim"
cp "$here"/shim/*.h "$out/kbuild/shim/"
make -s -C "$kdir" M="$out/kbuild" CONTEGO_SRC="$src" modules
cp "$out/kbuild/contego.ko" "$out/contego.ko"
echo "kernel/build.sh: $out/contego.ko ($(basename "$kdir"))" >&2
