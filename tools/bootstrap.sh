#!/usr/bin/env bash
# Installs every Debian 12 package that contego's build, tests, fuzzers,
# cross-build and plots need (--cross-arm64: the arm64 libraries of the
# cross-built package instead). Idempotent and non-interactive: packages that
# are already present are skipped, so a second run does no network I/O.
set -euo pipefail

packages=(
  # toolchain and build
  build-essential g++ cmake ninja-build pkg-config git ccache
  clang llvm libclang-rt-14-dev clang-format clang-tidy
  # libraries (see docs/libraries.md for why each one)
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev libfmt-dev nlohmann-json3-dev libseccomp-dev libi2c-dev libssl-dev
  libsystemd-dev
  # cross-build of the trusted core for the paper's Cortex-A53, run under qemu
  g++-aarch64-linux-gnu qemu-user
  # plots and measurements
  gnuplot-nox valgrind
  # real, unmodified I2C clients for end-to-end tests
  i2c-tools python3 python3-smbus python3-smbus2 python3-periphery
  # the real-kernel test bed (tests/vm): Debian's kernel booted in QEMU with a
  # busybox initramfs; seabios boots it without KVM, cpio packs the initramfs
  qemu-system-x86 seabios busybox-static cpio xz-utils
  # the booted Debian guest (tests/vm/booted): a Debian 12 root file system
  # made from Debian's archive, systemd as PID 1
  mmdebstrap
  # package checks (tools/check_package.sh): lintian, and devscripts for
  # hardening-check
  lintian devscripts
  # signed policy bundles (src/bundle/minisign.h): the real tool signs in
  # the tests, which verify with libcrypto
  minisign
  # contego-dkms (docs/kernel-client.md): CTest kmod.dkms builds the
  # package's module with DKMS's own tool against Debian's headers
  dkms
)

# contego.ko (kernel/build.sh, docs/kernel-client.md) builds against the
# headers of the test bed's kernel: the ABI package linux-image-amd64 points
# at today (resolved as tests/vm/fetch-kernel.sh does, never hard-coded).
if [[ "${1:-}" != --cross-arm64 && $(dpkg --print-architecture) == amd64 ]]; then
  kpkg=$(apt-cache depends linux-image-amd64 2>/dev/null |
    awk '/Depends: linux-image-[0-9]/ { print $2; exit }')
  if [[ -n "$kpkg" ]]; then packages+=("linux-headers-${kpkg#linux-image-}"); fi
  # kmod.kernels (kernel/kernels_test.sh) builds contego.ko against the
  # archive's newest amd64 kernel too (bookworm carries 6.12 beside 6.1),
  # with headers it unpacks, not installs: their host tools are this kbuild.
  newest=$(apt-cache search --names-only '^linux-headers-[0-9][^ ]*-amd64$' 2>/dev/null |
    awk '{ print $1 }' | grep -v -e '-cloud-amd64$' -e '-rt-amd64$' | sort -V | tail -n1 || true)
  if [[ -n "$newest" ]]; then
    kbuild=$(apt-cache depends "$newest" | awk '/Depends: linux-kbuild-/ { print $2; exit }')
    if [[ -n "$kbuild" ]]; then packages+=("$kbuild"); fi
  fi
fi

# --cross-arm64 (tools/package.sh --arch arm64, the arm64 test bed): the
# arm64 libraries the cross-built package links against, from Debian's
# archive as multiarch packages, instead of the list above; and for the test
# bed on Debian's arm64 kernel (tests/vm/run.sh --arch arm64): QEMU's aarch64
# system emulator, Debian's kernel source and kbuild tools to cross-build
# i2c-stub (which that kernel lacks), mmdebstrap to unpack the guest's arm64
# user space. The kernel, its headers and that user space are fetched into a
# cache by tests/vm, not installed.
if [[ "${1:-}" == --cross-arm64 ]]; then
  packages=(g++-aarch64-linux-gnu gcc-aarch64-linux-gnu qemu-user
    libfmt-dev:arm64 libssl-dev:arm64 libseccomp-dev:arm64 libsystemd-dev:arm64
    qemu-system-arm linux-source-6.1 linux-kbuild-6.1 mmdebstrap libgtest-dev)
  if ! dpkg --print-foreign-architectures | grep -qx arm64; then
    echo "bootstrap: dpkg --add-architecture arm64"
    if [[ $(id -u) -ne 0 ]]; then sudo dpkg --add-architecture arm64; else dpkg --add-architecture arm64; fi
  fi
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "bootstrap: all ${#packages[@]} packages present"
  exit 0
fi

sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
echo "bootstrap: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
