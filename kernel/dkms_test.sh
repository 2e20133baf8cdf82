#!/usr/bin/env bash
# kmod.dkms: the package contego-dkms's source tree builds with DKMS's own
# tool. Installs the dkms component of BUILD_DIR (the files the package
# holds, cmake/ContegoDkms.cmake) under WORK_DIR, then `dkms add` and `dkms
# build` in private DKMS trees (the machine's /var/lib/dkms is left alone)
# against Debian's headers of the test bed's kernel, and checks the module
# DKMS built: its vermagic names that kernel and the core is linked in.
# Installing and loading it is the booted guest's part (tests/vm/booted).
#
# Usage: kernel/dkms_test.sh BUILD_DIR WORK_DIR [KDIR]
# Exit 77 (skip) without root (DKMS wants it), dkms or the headers. DKMS may
# create its signing key in /var/lib/dkms (mok.key, mok.pub) on first use,
# as it would on any machine where it builds a module.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=${1:?usage: kernel/dkms_test.sh BUILD_DIR WORK_DIR [KDIR]}
work=${2:?usage: kernel/dkms_test.sh BUILD_DIR WORK_DIR [KDIR]}
skip() { echo "kmod.dkms: SKIP: $*" >&2; exit 77; }
fail() { echo "kmod.dkms: FAIL: $*" >&2; exit 1; }
command -v dkms >/dev/null || skip "dkms not installed (bash tools/bootstrap.sh)"
[[ $(id -u) == 0 ]] || skip "dkms add/build need root"
KB_NAME=kmod.dkms
. "$here/kbuild-env.sh"
rm -rf "$work"
kbuild_args "$work/unused" "${3:-}"
kver=${KB_KDIR##*/linux-headers-}

cmake --install "$build" --component dkms --prefix "$work/usr" >/dev/null
version=$(sed -n 's/^PACKAGE_VERSION="\(.*\)"$/\1/p' "$work"/usr/src/contego-*/dkms.conf)
[[ -n $version && -f $work/usr/src/contego-$version/dkms.conf ]] ||
  fail "no usr/src/contego-VERSION/dkms.conf in the dkms component"
trees=(--sourcetree "$work/usr/src" --dkmstree "$work/dkms" --installtree "$work/modules")
mkdir -p "$work/dkms" "$work/modules"
dkms add -m contego -v "$version" "${trees[@]}" || fail "dkms add"
if ! dkms build -m contego -v "$version" -k "$kver" --kernelsourcedir "$KB_KDIR" "${trees[@]}"; then
  cat "$work/dkms/contego/$version/build/make.log" >&2 || true
  fail "dkms build for $kver"
fi
ko=$(find "$work/dkms/contego/$version/$kver" -name 'contego.ko*' | head -n1)
[[ -n $ko ]] || fail "dkms build left no contego.ko under $work/dkms/contego/$version/$kver"
vermagic=$(modinfo -F vermagic "$ko")
[[ $vermagic == "$kver "* ]] || fail "$ko: vermagic '$vermagic' is not $kver's"
# nm's whole output first: `grep -q` would stop reading early, and nm's
# SIGPIPE fail the pipeline under pipefail.
symbols=$(nm "$ko")
grep -qw contego_check <<<"$symbols" || fail "$ko has no contego_check: the core is not linked in"
status=$(dkms status -m contego -v "$version" "${trees[@]}")
echo "kmod.dkms: $status"
[[ $status == *"$kver"*": built"* ]] || fail "dkms status says '$status'"
echo "kmod.dkms: PASS: $ko ($vermagic)"
