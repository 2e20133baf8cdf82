#!/usr/bin/env bash
# Installs the Debian 12 packages contego needs for one purpose, and only
# those. Idempotent and non-interactive: packages already present are
# skipped, so a second run does no network I/O.
# Usage: tools/bootstrap.sh [demo|package|test] [--print]
#        tools/bootstrap.sh --cross-arm64 [--print]
#   demo     build contego and run the demo (tools/demo.sh): the toolchain,
#            the libraries and gnuplot
#   package  build and check the Debian packages (tools/package.sh): demo's
#            set and the package checks (lintian, hardening-check)
#   test     everything the tests, fuzzers, test beds and benches use
#            (tools/test.sh; the default)
#   --cross-arm64  the arm64 libraries of the cross-built package and the
#            arm64 test bed's tools instead
#   --print  print the packages of that purpose, one per line; install nothing
set -euo pipefail

purpose=test
print=0
for arg in "$@"; do
  case $arg in
    demo | package | test | --cross-arm64) purpose=$arg ;;
    --print) print=1 ;;
    *) echo "usage: tools/bootstrap.sh [demo|package|test|--cross-arm64] [--print]" >&2; exit 2 ;;
  esac
done

# demo: what `cmake --preset release` needs to configure and build contego
# (docs/libraries.md says why each library), and gnuplot for the figures.
packages=(
  build-essential g++ cmake ninja-build pkg-config ccache
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev libfmt-dev nlohmann-json3-dev libseccomp-dev libi2c-dev libssl-dev
  libsystemd-dev
  gnuplot-nox
)
if [[ $purpose == package || $purpose == test ]]; then
  # tools/check_package.sh: lintian, and devscripts for hardening-check
  packages+=(lintian devscripts file)
fi
if [[ $purpose == test ]]; then
  packages+=(
    git clang llvm libclang-rt-14-dev clang-format clang-tidy
    # cross-build of the trusted core for the paper's Cortex-A53, run under qemu
    g++-aarch64-linux-gnu qemu-user
    # measurements
    valgrind
    # real, unmodified I2C clients for end-to-end tests
    i2c-tools python3 python3-smbus python3-smbus2 python3-periphery
    # the real-kernel test bed (tests/vm): Debian's kernel booted in QEMU with a
    # busybox initramfs; seabios boots it without KVM, cpio packs the initramfs
    qemu-system-x86 seabios busybox-static cpio xz-utils
    # the booted Debian guest (tests/vm/booted): a Debian 12 root file system
    # made from Debian's archive, systemd as PID 1
    mmdebstrap
    # signed policy bundles (src/bundle/minisign.h): the real tool signs in
    # the tests, which verify with libcrypto
    minisign
    # contego-dkms (docs/kernel-client.md): CTest kmod.dkms builds the
    # package's module with DKMS's own tool against Debian's headers
    dkms
    # kernel/lint.sh (CTest kmod.lint): sparse, and checkpatch.pl from
    # Debian's kernel source (the arm64 test bed builds i2c-stub from it too)
    sparse linux-source-6.1
  )
fi

# contego.ko (kernel/build.sh, docs/kernel-client.md) builds against the
# headers of the test bed's kernel: the ABI package linux-image-amd64 points
# at today (resolved as tests/vm/fetch-kernel.sh does, never hard-coded).
if [[ $purpose == test && $(dpkg --print-architecture) == amd64 ]]; then
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
# cache by tests/vm, not installed. The arm64 booted guest (tests/vm/booted.sh
# --arch arm64) has mmdebstrap make and configure a whole arm64 Debian, whose
# maintainer scripts run here under qemu-user-static through binfmt_misc
# (binfmt-support registers it where systemd does not; mmdebstrap asks
# arch-test whether arm64 programs run here).
if [[ $purpose == --cross-arm64 ]]; then
  packages=(g++-aarch64-linux-gnu gcc-aarch64-linux-gnu qemu-user
    libfmt-dev:arm64 libssl-dev:arm64 libseccomp-dev:arm64 libsystemd-dev:arm64
    qemu-system-arm linux-source-6.1 linux-kbuild-6.1 mmdebstrap libgtest-dev
    qemu-user-static binfmt-support arch-test cpio)
  if ((!print)) && ! dpkg --print-foreign-architectures | grep -qx arm64; then
    echo "bootstrap: dpkg --add-architecture arm64"
    if [[ $(id -u) -ne 0 ]]; then sudo dpkg --add-architecture arm64; else dpkg --add-architecture arm64; fi
  fi
fi

if ((print)); then
  printf '%s\n' "${packages[@]}"
  exit 0
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "bootstrap: all ${#packages[@]} packages for $purpose present"
  exit 0
fi

sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
echo "bootstrap: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
