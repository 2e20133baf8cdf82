#!/usr/bin/env bash
# contego.ko's driver as a kernel maintainer reads it (docs/kernel-client.md,
# "The module's sources"):
#   checkpatch  the kernel's scripts/checkpatch.pl, taken from Debian's
#               linux-source-6.1, on every driver file and the UAPI header:
#               0 errors, 0 warnings, with the one exception named below
#   W=1 sparse  the module built with W=1 (the extra warnings) and C=2
#               CHECK=sparse (address spaces, endianness, locking
#               annotations): no warning or error in the driver's files
#
# Usage: kernel/lint.sh OUT_DIR [KDIR]
# Exit 77 (skip) without sparse, linux-source-6.1 or the kernel headers
# (bash tools/bootstrap.sh installs them).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/.." && pwd)
KB_NAME=kernel/lint.sh
. "$here/kbuild-env.sh"
kbuild_args "$@"
out=$KB_OUT
command -v sparse >/dev/null || { echo "kernel/lint.sh: SKIP: no sparse (bash tools/bootstrap.sh)" >&2; exit 77; }
tarball=$(ls /usr/src/linux-source-6.1.tar.* 2>/dev/null | head -n1 || true)
[[ -n "$tarball" ]] || {
  echo "kernel/lint.sh: SKIP: no /usr/src/linux-source-6.1.tar.* for checkpatch.pl (bash tools/bootstrap.sh)" >&2
  exit 77
}

fails=0
files=("$here"/contego*.c "$here"/contego*.h "$here"/kunit/contego_kunit.c "$here"/include/uapi/linux/*.h)

# checkpatch.pl and the two data files it reads, unpacked once per tarball.
cp_dir=$out/checkpatch
stamp="$tarball $(stat -c %Y "$tarball")"
if [[ ! -f "$cp_dir/stamp" || "$(cat "$cp_dir/stamp")" != "$stamp" ]]; then
  rm -rf "$cp_dir" && mkdir -p "$cp_dir"
  tar -xf "$tarball" -C "$cp_dir" --strip-components=2 linux-source-6.1/scripts/checkpatch.pl \
    linux-source-6.1/scripts/spelling.txt linux-source-6.1/scripts/const_structs.checkpatch
  echo "$stamp" >"$cp_dir/stamp"
fi
checkpatch() { perl "$cp_dir/checkpatch.pl" --no-tree --file --terse --show-types "$@"; }
# The exception: contego_compat.h is where the tests of the kernel's version
# live (an out-of-tree module built for 6.1 to 6.12: LINUX_VERSION_CODE, which
# checkpatch also reads as a constant on the left of a comparison). Every
# other file has no version test.
others=()
for f in "${files[@]}"; do [[ $(basename "$f") == contego_compat.h ]] || others+=("$f"); done
report=$( (checkpatch "${others[@]}"
  checkpatch --ignore LINUX_VERSION_CODE,CONSTANT_COMPARISON "$here/contego_compat.h") 2>&1 |
  grep -E ': (ERROR|WARNING):' || true)
if [[ -n "$report" ]]; then
  echo "$report"
  echo "kernel/lint.sh: checkpatch: $(grep -c ERROR <<<"$report" || true) errors, $(grep -c WARNING <<<"$report" || true) warnings" >&2
  fails=1
else
  echo "kernel/lint.sh: checkpatch: 0 errors, 0 warnings in ${#files[@]} files ($(cat "${files[@]}" | wc -l) lines)"
fi

# W=1 and sparse, on a copy of the module's sources (as kernel/build.sh).
kb=$out/kbuild
rm -rf "$kb" && mkdir -p "$kb/shim" "$kb/include/uapi/linux"
cp "$here"/Kbuild "$here"/contego*.c "$here"/contego*.h "$kb/"
cp "$here"/shim/*.h "$kb/shim/"
cp "$here"/include/uapi/linux/*.h "$kb/include/uapi/linux/"
log=$out/w1-sparse.log
# The driver's objects alone: sparse reads C, and the core's C++ objects
# (kernel/build.sh links them) would only add their compile time.
objs=()
for f in "$here"/contego*.c; do objs+=("$(basename "${f%.c}").o"); done
if ! make -C "$KB_KDIR" M="$kb" CONTEGO_SRC="$src" "${KB_CROSS[@]}" W=1 C=2 CHECK=sparse "${objs[@]}" >"$log" 2>&1; then
  tail -n 40 "$log"
  echo "kernel/lint.sh: the W=1 sparse build failed (log: $log)" >&2
  exit 1
fi
checked=$(grep -c '^  CHECK' "$log" || true)
found=$(grep -E 'contego[a-z_]*\.[ch]:[0-9]+:[0-9]+: (warning|error)' "$log" || true)
if [[ -n "$found" ]]; then
  echo "$found"
  echo "kernel/lint.sh: W=1 + sparse: $(wc -l <<<"$found") findings" >&2
  fails=1
elif ((checked == 0)); then
  echo "kernel/lint.sh: sparse checked no file (log: $log)" >&2
  fails=1
else
  echo "kernel/lint.sh: W=1 + sparse: 0 warnings, $checked files checked ($(basename "$KB_KDIR"))"
fi
exit $fails
