#!/usr/bin/env bash
# Unpacks KUnit (lib/kunit) from Debian's linux-source-6.1 into DEST, to be
# built as an out-of-tree kunit.ko for a Debian 6.1 kernel, which is built
# without it (# CONFIG_KUNIT is not set). Called by kernel/build.sh --kunit.
#
# Two things KUnit takes from a kernel built with it are not in this one,
# so two changes are made to its test.c, and nothing else:
#   - struct task_struct has no kunit_test member: the test being run is a
#     variable of the module instead (KUnit runs one test at a time);
#   - struct module has no kunit_suites members, so KUnit's module notifier
#     is left out: a test module hands its suites to __kunit_test_suites_init
#     itself (kernel/kunit/contego_kunit.c).
# The module is built without CONFIG_KUNIT, so every kernel structure it
# sees has the running kernel's layout.
#
# Usage: kernel/kunit/unpack.sh KDIR DEST
# Exit 1, printing why on stdout, when it cannot (no source, another kernel).
set -euo pipefail
kdir=$1 dest=$2
release=$(cat "$kdir/include/config/kernel.release" 2>/dev/null || echo unknown)
[[ "$release" == 6.1.* ]] || { echo "kernel $release: KUnit's source here is linux-source-6.1's"; exit 1; }
tarball=$(ls /usr/src/linux-source-6.1.tar.* 2>/dev/null | head -n1 || true)
[[ -n "$tarball" ]] || { echo "no /usr/src/linux-source-6.1.tar.* (bash tools/bootstrap.sh installs it)"; exit 1; }
rm -rf "$dest" && mkdir -p "$dest"
files=(test.c resource.c string-stream.c string-stream.h assert.c try-catch.c try-catch-impl.h
  executor.c debugfs.h)
tar -xf "$tarball" -C "$dest" --strip-components=3 "${files[@]/#/linux-source-6.1/lib/kunit/}" ||
  { echo "$tarball holds no lib/kunit"; exit 1; }
test_c=$dest/test.c
n_current=$(grep -c 'current->kunit_test' "$test_c" || true)
n_modules=$(grep -c '^#ifdef CONFIG_MODULES$' "$test_c" || true)
# The counts pin the source these changes were written against.
[[ "$n_current" == 7 && "$n_modules" == 3 ]] ||
  { echo "lib/kunit/test.c is not the one expected ($n_current, $n_modules)"; exit 1; }
sed -i -e 's/current->kunit_test/ct_kunit_running/g' \
  -e 's|^#ifdef CONFIG_MODULES$|#if 0 /* no kunit_suites in this kernel'"'"'s struct module */|' \
  -e '0,/^#include "try-catch-impl.h"$/s//#include "try-catch-impl.h"\n\n\/* The test being run (no kunit_test in this kernel'"'"'s task_struct). *\/\nstatic struct kunit *ct_kunit_running;/' \
  "$test_c"
