#!/usr/bin/env bash
# Builds contego's Debian packages (docs/packaging.md): amd64 natively and
# arm64 cross-built with Debian's aarch64 toolchain against Debian's
# multiarch arm64 libraries, each with the `package` preset (-O2, stripped,
# debug symbols split off into -dbgsym), then checks each package
# (tools/check_package.sh: no build-tree path in the file list, no source or
# build path in the binaries).
# Usage: tools/package.sh [--arch amd64|arm64] ... [--out DIR]
#   default: both architectures, packages in out/packages/
set -euo pipefail
cd "$(dirname "$0")/.."
archs=()
out=out/packages
while (($#)); do
  case $1 in
    --arch) archs+=("$2"); shift 2 ;;
    --out) out=$2; shift 2 ;;
    *) echo "usage: tools/package.sh [--arch amd64|arm64] ... [--out DIR]" >&2; exit 2 ;;
  esac
done
((${#archs[@]})) || archs=(amd64 arm64)

bash tools/bootstrap.sh package
mkdir -p "$out"
for arch in "${archs[@]}"; do
  case $arch in
    amd64) preset=package ;;
    arm64) preset=package-arm64; bash tools/bootstrap.sh --cross-arm64 ;;
    *) echo "package.sh: unknown architecture $arch (amd64 or arm64)" >&2; exit 2 ;;
  esac
  printf '\n==== %s package ====\n' "$arch"
  start=$SECONDS
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset"
  rm -rf "build/$preset/cpack"
  # dpkg-shlibdeps resolves the libraries of the package's architecture.
  DEB_HOST_ARCH=$arch cpack --config "build/$preset/CPackConfig.cmake" -B "build/$preset/cpack"
  debs=()
  for f in "build/$preset/cpack"/*.deb "build/$preset/cpack"/*.ddeb; do
    [[ -e $f ]] || continue
    cp "$f" "$out/"
    debs+=("$out/$(basename "$f")")
  done
  bash tools/check_package.sh --arch "$arch" --forbid "$PWD" "${debs[@]}"
  echo "package.sh: $arch done in $((SECONDS - start)) s"
done
