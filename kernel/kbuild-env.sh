# Sourced by the scripts that build an out-of-tree module (kernel/build.sh
# for contego.ko, tests/vm/kmod/build.sh for the test bed's adapter): parses
# their common arguments and resolves the Debian linux-headers to build
# against, once for all of them.
#
#   kbuild_args "$@"   [--arch amd64|arm64] OUT_DIR [KDIR]
#
# Sets KB_ARCH, KB_CROSS (make variables for a cross build, an array),
# KB_OUT (absolute, created) and KB_KDIR (absolute). KDIR defaults to
# /usr/src/linux-headers-<ABI> of the kernel linux-image-amd64 points at (the
# test bed's kernel, resolved as tests/vm/fetch-kernel.sh does); --arch arm64
# on an amd64 host cross-builds with Debian's aarch64-linux-gnu- tools and
# needs KDIR (arm64 headers: the arm64 test bed's kernel cache keeps them).
# Exits 77 (skip) when the headers or the cross tools are not installed;
# KB_NAME (the calling script's name) prefixes the messages.
kbuild_args() {
  local name=${KB_NAME:-kbuild} host
  host=$(dpkg --print-architecture 2>/dev/null || echo amd64)
  KB_ARCH=$host
  if [[ "${1:-}" == --arch ]]; then
    KB_ARCH=${2:?--arch needs amd64 or arm64}
    shift 2
  fi
  KB_CROSS=()
  if [[ "$KB_ARCH" != "$host" ]]; then
    case "$KB_ARCH" in
      arm64) KB_CROSS=(ARCH=arm64 CROSS_COMPILE=aarch64-linux-gnu-) ;;
      *) echo "$name: cannot cross-build for $KB_ARCH (arm64 only)" >&2; exit 2 ;;
    esac
    command -v aarch64-linux-gnu-gcc >/dev/null || {
      echo "$name: SKIP: no aarch64-linux-gnu-gcc (bash tools/bootstrap.sh --cross-arm64)" >&2
      exit 77
    }
    [[ -n "${2:-}" ]] || { echo "$name: SKIP: --arch $KB_ARCH needs KDIR (arm64 headers)" >&2; exit 77; }
  fi
  KB_OUT=${1:?usage: $name [--arch amd64|arm64] OUT_DIR [KDIR]}
  KB_KDIR=${2:-}
  if [[ -z "$KB_KDIR" ]]; then
    local pkg
    pkg=$(apt-cache depends linux-image-amd64 2>/dev/null |
      awk '/Depends: linux-image-[0-9]/ { print $2; exit }')
    [[ -n "$pkg" ]] || { echo "$name: cannot resolve linux-image-amd64's kernel" >&2; exit 77; }
    KB_KDIR=/usr/src/linux-headers-${pkg#linux-image-}
  fi
  if [[ ! -f "$KB_KDIR/Makefile" ]]; then
    echo "$name: SKIP: no kernel headers at $KB_KDIR (bash tools/bootstrap.sh installs them)" >&2
    exit 77
  fi
  mkdir -p "$KB_OUT/kbuild"
  KB_OUT=$(cd "$KB_OUT" && pwd)
  KB_KDIR=$(cd "$KB_KDIR" && pwd -P)
}
