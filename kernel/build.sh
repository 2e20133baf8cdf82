#!/usr/bin/env bash
# Builds contego.ko (docs/kernel-client.md) with Kbuild against Debian's
# linux-headers of the test bed's kernel: the one linux-image-amd64 points at
# (resolved as tests/vm/fetch-kernel.sh does), or KDIR if given.
#
# Usage: kernel/build.sh [--kunit] [--arch amd64|arm64] OUT_DIR [KDIR]
#   OUT_DIR receives contego.ko (the Kbuild tree is built in OUT_DIR/kbuild).
#   --kunit also builds the KUnit tests of the pure parts (kernel/kunit):
#   contego-kunit.ko, and kunit.ko from Debian's linux-source-6.1, since
#   Debian's kernels are built without KUnit (# CONFIG_KUNIT is not set).
#   Without that source, or for a kernel other than 6.1, they are not built
#   and OUT_DIR/kunit-skipped says why.
#   --arch arm64 on an amd64 host cross-builds with Debian's
#   aarch64-linux-gnu-gcc/g++ against arm64 headers, which KDIR must name
#   (the arm64 test bed's kernel cache keeps them: tests/vm/fetch-kernel.sh).
# Exit 77 (skip) when the headers are not installed (bash tools/bootstrap.sh).
# The arguments and the headers are resolved by kernel/kbuild-env.sh.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/.." && pwd)
KB_NAME=kernel/build.sh
. "$here/kbuild-env.sh"
kunit=0
if [[ "${1:-}" == --kunit ]]; then
  kunit=1
  shift
fi
kbuild_args "$@"
if ((${#KB_CROSS[@]})); then
  # The core is C++: the cross g++ too.
  command -v aarch64-linux-gnu-g++ >/dev/null || {
    echo "kernel/build.sh: SKIP: no aarch64-linux-gnu-g++ (bash tools/bootstrap.sh --cross-arm64)" >&2
    exit 77
  }
fi
out=$KB_OUT
# Kbuild builds in the module's directory: a copy, so the source tree stays clean.
cp "$here"/Kbuild "$here"/contego*.c "$here"/contego*.h "$out/kbuild/"
mkdir -p "$out/kbuild/shim" "$out/kbuild/include/uapi/linux"
cp "$here"/shim/*.h "$out/kbuild/shim/"
cp "$here"/include/uapi/linux/*.h "$out/kbuild/include/uapi/linux/"
kunit_args=()
rm -f "$out/kunit-skipped" "$out/kunit.ko" "$out/contego-kunit.ko"
if ((kunit)); then
  if why=$(bash "$here/kunit/unpack.sh" "$KB_KDIR" "$out/kbuild/kunit"); then
    cp "$here"/kunit/contego_kunit.c "$out/kbuild/"
    kunit_args=(CONTEGO_KUNIT=1)
  else
    echo "$why" >"$out/kunit-skipped"
    echo "kernel/build.sh: KUnit tests not built: $why" >&2
  fi
fi
make -s -C "$KB_KDIR" M="$out/kbuild" CONTEGO_SRC="$src" "${KB_CROSS[@]}" "${kunit_args[@]}" modules
cp "$out/kbuild/contego.ko" "$out/contego.ko"
if ((${#kunit_args[@]})); then
  cp "$out/kbuild/kunit.ko" "$out/kbuild/contego-kunit.ko" "$out/"
fi
echo "kernel/build.sh: $out/contego.ko ($(basename "$KB_KDIR"))" >&2
