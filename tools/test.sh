#!/usr/bin/env bash
# The whole test suite: installs dependencies, then builds and tests every
# mode (debug, ASan+UBSan, TSan for the monitor and supervisor, fuzz smoke
# runs, the amd64 Debian package). Exits non-zero on any failure.
# Usage: tools/test.sh [--quick]   (--quick: debug build and CTest only)
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
[[ "${1:-}" == "--quick" ]] && quick=1

bash tools/bootstrap.sh
# The arm64 cross toolchain, libraries and QEMU for the arm64 test bed
# (vm.testbed_arm64 in the dev build's CTest; it skips without them).
bash tools/bootstrap.sh --cross-arm64

step() { printf '\n==== %s ====\n' "$*"; }

# Formatting first: it takes a second and fails before any build does.
if command -v clang-format >/dev/null; then
  step "clang-format check"
  git ls-files '*.h' '*.cc' | xargs clang-format --dry-run --Werror
fi

step "debug build + tests"
cmake --preset dev >/dev/null
cmake --build --preset dev
ctest --preset dev

((quick)) && exit 0

step "asan+ubsan build + tests"
cmake --preset asan-ubsan >/dev/null
cmake --build --preset asan-ubsan
ctest --preset asan-ubsan

step "tsan build + monitor, supervisor and gate tests"
cmake --preset tsan >/dev/null
cmake --build --preset tsan --target supervisor_test monitor_test policy_e2e_test gate_test \
  seccomp_filter_test
ctest --preset tsan -L 'monitor|supervisor|gate'

if [[ -f fuzz/CMakeLists.txt ]]; then
  step "fuzz smoke runs (clang, libFuzzer)"
  cmake --preset fuzz >/dev/null
  cmake --build --preset fuzz
  bash tools/fuzz_smoke.sh build/fuzz "${CONTEGO_FUZZ_SECONDS:-10}"
fi

# The amd64 Debian package, built and checked (docs/packaging.md); the arm64
# one is `tools/package.sh --arch arm64`, as long again, not run here.
step "amd64 Debian package"
bash tools/package.sh --arch amd64

step "all tests passed"
