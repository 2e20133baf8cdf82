#!/usr/bin/env bash
# kmod.kernels: contego.ko builds for the kernels a Debian 12 robot may run
# besides the test bed's: the PREEMPT_RT flavour of the test bed's kernel
# (the real-time kernel of a control system) and the newest amd64 kernel of
# the archive, generic and PREEMPT_RT (bookworm carries 6.12 beside 6.1), as
# DKMS would build it there (package contego-dkms). The headers are fetched
# and unpacked, not installed (kernel/fetch-headers.sh); each module must
# link (modpost: every symbol it uses exported to it) and carry its
# kernel's vermagic. Loading them is not tested here: the test bed boots
# the kernel linux-image-amd64 points at.
#
# Usage: kernel/kernels_test.sh WORK_DIR
# Exit 77 (skip) when no such kernel's headers can be had, with the reasons.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
work=${1:?usage: kernel/kernels_test.sh WORK_DIR}
rm -rf "$work"
mkdir -p "$work"

bed=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ { print $2; exit }')
[[ -n $bed ]] || { echo "kmod.kernels: SKIP: cannot resolve linux-image-amd64's kernel" >&2; exit 77; }
bed=${bed#linux-image-}
newest() { # the archive's newest amd64 headers package of a flavour: generic or rt
  local list
  list=$(apt-cache search --names-only '^linux-headers-[0-9][^ ]*-amd64$' | awk '{ print $1 }' |
    grep -v -e '-cloud-amd64$' || true)
  if [[ $1 == rt ]]; then grep -e '-rt-amd64$' <<<"$list"; else grep -v -e '-rt-amd64$' <<<"$list"; fi |
    sort -V | tail -n1
}
kernels=("linux-headers-${bed%-amd64}-rt-amd64")
for flavour in generic rt; do
  k=$(newest "$flavour")
  [[ -n $k && $k != "linux-headers-$bed" && ! " ${kernels[*]} " =~ " $k " ]] && kernels+=("$k")
done

built=0 skipped=()
for pkg in "${kernels[@]}"; do
  rc=0
  kdir=$(bash "$here/fetch-headers.sh" "$pkg") || rc=$?
  if ((rc == 77)); then skipped+=("$pkg"); continue; fi
  ((rc == 0)) || { echo "kmod.kernels: FAIL: fetching $pkg" >&2; exit 1; }
  release=${pkg#linux-headers-}
  out=$work/$release
  if ! bash "$here/build.sh" "$out" "$kdir" >"$work/$release.log" 2>&1; then
    cat "$work/$release.log" >&2
    echo "kmod.kernels: FAIL: contego.ko does not build for $release" >&2
    exit 1
  fi
  vermagic=$(modinfo -F vermagic "$out/contego.ko")
  [[ $vermagic == "$release "* ]] || { echo "kmod.kernels: FAIL: $release: vermagic '$vermagic'" >&2; exit 1; }
  echo "kmod.kernels: $release: contego.ko builds ($vermagic)"
  built=$((built + 1))
done
if ((${#skipped[@]})); then echo "kmod.kernels: not fetched: ${skipped[*]} (see above)" >&2; fi
((built > 0)) || { echo "kmod.kernels: SKIP: no kernel's headers to build against" >&2; exit 77; }
((${#skipped[@]} == 0)) || { echo "kmod.kernels: SKIP: $built built, ${#skipped[@]} not tried" >&2; exit 77; }
echo "kmod.kernels: PASS: $built kernels"
