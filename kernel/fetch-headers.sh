#!/usr/bin/env bash
# Fetches a Debian kernel's linux-headers package and its -common half with
# apt-get download and unpacks them into a cache, without installing them (a
# later kernel's headers package depends on its image: installing it would
# install a kernel on the build machine). Their scripts and tools are the
# host's linux-kbuild-VERSION, which must be installed (tools/bootstrap.sh
# installs the one of the archive's newest amd64 kernel). Prints the headers
# directory, a KDIR for kernel/build.sh.
#
# Usage: kernel/fetch-headers.sh HEADERS_PACKAGE   (e.g. linux-headers-6.12.117+deb12-amd64)
# Env:   CONTEGO_VM_CACHE   cache root (as tests/vm/fetch-kernel.sh)
# Exit 77 (skip) when the package or its kbuild tools are not to be had.
set -euo pipefail
pkg=${1:?usage: kernel/fetch-headers.sh HEADERS_PACKAGE}
skip() { echo "fetch-headers: SKIP: $*" >&2; exit 77; }
cache_root=${CONTEGO_VM_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/contego-vm}
version=$(apt-cache policy "$pkg" 2>/dev/null | awk '/Candidate:/ { print $2 }')
[[ -n $version && $version != "(none)" ]] || skip "$pkg is not in the archive (apt-get update?)"
common=$(apt-cache depends "$pkg" | awk '/Depends: linux-headers-.*-common/ { print $2; exit }')
kbuild=$(apt-cache depends "$pkg" | awk '/Depends: linux-kbuild-/ { print $2; exit }')
[[ -n $common && -n $kbuild ]] || skip "cannot resolve $pkg's -common and kbuild packages"
[[ -d /usr/lib/$kbuild ]] || skip "$kbuild is not installed (bash tools/bootstrap.sh)"
dir=$cache_root/headers/$pkg/$version
hdir=$dir/root/usr/src/${pkg#*/}
if [[ -f $dir/.complete ]]; then
  echo "$hdir"
  exit 0
fi
rm -rf "$dir"
mkdir -p "$dir/debs"
chmod 755 "$dir" "$dir/debs" # apt-get download drops to the _apt user
(cd "$dir/debs" && apt-get download -q "$pkg=$version" "$common=$version" >&2) ||
  skip "apt-get download $pkg=$version failed (network to the Debian archive?)"
for deb in "$dir"/debs/*.deb; do dpkg -x "$deb" "$dir/root"; done
rm -rf "$dir/debs"
[[ -f $hdir/Makefile ]] || { echo "fetch-headers: $pkg holds no usr/src/${pkg}/Makefile" >&2; exit 1; }
# The headers name their -common half and the kbuild tools by absolute
# paths: the unpacked copy, and the host's kbuild.
sed -i "s,^include /usr/src/,include $dir/root/usr/src/," "$hdir/Makefile"
mkdir -p "$dir/root/usr/lib"
ln -sfn "/usr/lib/$kbuild" "$dir/root/usr/lib/$kbuild"
touch "$dir/.complete"
echo "$hdir"
