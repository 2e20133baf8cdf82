#!/usr/bin/env bash
# The guest's user space for a foreign architecture (arm64 on an amd64
# host): busybox-static, i2c-tools, python3 with smbus, smbus2 and periphery,
# and the shared libraries contego links, as Debian's arm64 packages,
# unpacked (never installed or configured: mmdebstrap --variant=extract
# resolves their dependencies) into a cache outside the clone. The amd64 bed
# takes the same programs from the host instead.
#
# The cache is keyed by the candidate versions of the packages whose ABI the
# cross-built binaries depend on, so a security update fetches a new tree and
# an unchanged archive does no network I/O. Prints the tree's root directory.
#
# Usage: tests/vm/fetch-userland.sh --arch arm64
# Env:   CONTEGO_VM_CACHE (see fetch-kernel.sh)
set -euo pipefail

die() { echo "fetch-userland: $*" >&2; exit 1; }
[[ "${1:-}" == --arch && -n "${2:-}" ]] || die "usage: fetch-userland.sh --arch arm64"
arch=$2
cache_root=${CONTEGO_VM_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/contego-vm}
command -v mmdebstrap >/dev/null || die "mmdebstrap missing (bash tools/bootstrap.sh --cross-arm64)"

packages=(busybox-static i2c-tools python3.11-minimal libpython3.11-stdlib python3-smbus
  python3-smbus2 python3-periphery libstdc++6 libfmt9 libssl3 libseccomp2 libsystemd0)
# One apt-cache call for all of them (each call parses every package list).
abi=(libc6 libstdc++6 libssl3 libseccomp2 libsystemd0 libfmt9 python3.11-minimal i2c-tools)
key=$(apt-cache policy "${abi[@]/%/:$arch}" 2>/dev/null | awk '/^[^ ]/ { p = $1 } /Candidate:/ { print p "=" $2 }')
for p in "${abi[@]}"; do
  grep -q "^$p:$arch:=[^(]" <<<"$key" ||
    die "no $p:$arch in the package lists (dpkg --add-architecture $arch; apt-get update)"
done
key=$(printf '%s\n' "$key" "${packages[*]}" | sha256sum | cut -c1-16)
dir=$cache_root/userland-$arch/$key
if [[ -f "$dir/.complete" ]]; then
  echo "$dir/root"
  exit 0
fi

echo "fetch-userland: unpacking Debian's $arch ${packages[*]} into $dir" >&2
mkdir -p "$dir"
tmp=$(mktemp -d "$dir/.tmp.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
# The host's archive (bookworm with its updates and security suites), so
# the libraries match the arm64 -dev packages the binaries were linked with.
include=$(
  IFS=,
  echo "${packages[*]}"
)
mmdebstrap --quiet --mode=root --variant=extract --architectures="$arch" --include="$include" \
  --format=directory bookworm "$tmp/root" \
  "deb http://deb.debian.org/debian bookworm main" \
  "deb http://deb.debian.org/debian bookworm-updates main" \
  "deb http://deb.debian.org/debian-security bookworm-security main" >&2 ||
  die "mmdebstrap failed (network to the Debian archive?)"
# Only what a guest can use is kept: no documentation, locales or apt state.
rm -rf "$tmp/root/usr/share/doc" "$tmp/root/usr/share/man" "$tmp/root/usr/share/locale" \
  "$tmp/root/var/cache/apt" "$tmp/root/var/lib/apt"
rm -rf "$dir/root"
mv "$tmp/root" "$dir/root"
touch "$dir/.complete"
echo "$dir/root"
