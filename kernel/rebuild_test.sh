#!/usr/bin/env bash
# kmod.rebuild: Kbuild recompiles a core object when a header it includes
# changes, not only when its .cc does. Without it an incremental build links
# objects compiled against an old struct layout beside new ones (a core
# header once moved CheckerState's members and the module's transfer code
# then wrote outside them, timing-dependently). Builds a copy of the tree.
#
# Usage: kernel/rebuild_test.sh WORK_DIR   (exit 77: no kernel headers)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
work=${1:?usage: kernel/rebuild_test.sh WORK_DIR}
rm -rf "$work"
mkdir -p "$work/tree/src"
cp -r "$root/kernel" "$root/include" "$work/tree/"
cp -r "$root/src/core" "$root/src/i2cdev" "$work/tree/src/"
build() { bash "$work/tree/kernel/build.sh" "$work/out" >"$work/build.log" 2>&1 || {
  rc=$?; cat "$work/build.log" >&2; exit $rc; }; }
stamp() { stat -c %Y.%y "$work/out/kbuild/$1"; }

build
before_transfer=$(stamp core_transfer.o) before_crc=$(stamp core_crc32.o)
sleep 1.1
build
[[ $(stamp core_transfer.o) == "$before_transfer" ]] || {
  echo "FAIL: core_transfer.o rebuilt although nothing changed" >&2; exit 1; }
# state.h is included by transfer.cc, not by crc32.cc.
echo "// changed by kernel/rebuild_test.sh" >>"$work/tree/src/core/state.h"
build
[[ $(stamp core_transfer.o) != "$before_transfer" ]] || {
  echo "FAIL: src/core/state.h changed and core_transfer.o was not rebuilt" >&2; exit 1; }
[[ $(stamp core_crc32.o) == "$before_crc" ]] || {
  echo "FAIL: core_crc32.o rebuilt although none of its headers changed" >&2; exit 1; }
echo "kmod.rebuild: a header change rebuilds the objects that include it, and only those"
