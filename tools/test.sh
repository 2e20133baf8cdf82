#!/usr/bin/env bash
# The whole test suite: installs dependencies, then builds and tests every
# mode (the demo, debug, ASan+UBSan, TSan for the monitor and supervisor, fuzz smoke
# runs, the real-kernel test bed on amd64, the amd64 Debian package in a
# booted guest, the arm64 build and test bed; with CONTEGO_BOOTED_ARM64=1 also
# the arm64 package in an arm64 booted guest). Exits non-zero on any failure.
# Usage: tools/test.sh [--quick]   (--quick: the debug build and all its tests only)
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
[[ "${1:-}" == "--quick" ]] && quick=1

bash tools/bootstrap.sh test

# A compiler cache outside the clone (docs/libraries.md, ccache): a warm
# machine rebuilds every stage from it in minutes; a fresh one fills it. The
# base directory makes hits independent of where the clone is.
if command -v ccache >/dev/null; then
  export CCACHE_DIR="${CCACHE_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/ccache}"
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true
  export CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-6G}"
  export CMAKE_C_COMPILER_LAUNCHER=ccache CMAKE_CXX_COMPILER_LAUNCHER=ccache
  ccache --zero-stats >/dev/null
fi

# Each stage's header shows the disk space left (a full disk fails a build
# with an error that does not say why it filled) and the time the stage
# before it took; the last line sums them up.
stage_name="" stage_start=$SECONDS stage_times=()
end_stage() {
  if [[ -n "$stage_name" ]]; then stage_times+=("$(printf '%5ds  %s' $((SECONDS - stage_start)) "$stage_name")"); fi
}
step() {
  end_stage
  stage_name="$*" stage_start=$SECONDS
  printf '\n==== %s ==== (%s free, %ds so far)\n' "$*" "$(df -h --output=avail . | tail -n1 | tr -d ' ')" "$SECONDS"
}
report_times() {
  end_stage
  stage_name=""
  printf '\nstage times:\n'
  printf '  %s\n' "${stage_times[@]}"
  if command -v ccache >/dev/null; then ccache --show-stats 2>/dev/null | grep -iE 'hits|misses' | head -4 | sed 's/^/  ccache: /' || true; fi
}

# Under CI (CI=true) a stage's build tree is removed as soon as no later
# stage reads it: a CI machine has run out of disk with all the trees kept
# (about 4 GiB, README "Two commands"). A developer keeps them, for the next
# incremental build.
done_with() {
  if [[ "${CI:-}" == true ]]; then rm -rf "$@"; fi
}

# Formatting first: it takes a second and fails before any build does.
if command -v clang-format >/dev/null; then
  step "clang-format check"
  git ls-files '*.h' '*.cc' | xargs clang-format --dry-run --Werror
fi

if ((quick)); then
  step "debug build + tests"
  cmake --preset dev >/dev/null
  cmake --build --preset dev
  ctest --preset dev -E '^vm\.booted_guest$' -LE arm64
  report_times
  exit 0
fi

# The README's first command, as written: its own build (the demo preset),
# the three case studies and their figures. (Their outcomes are the sim
# tests' assertions; this proves the command a newcomer types.)
step "the demo (tools/demo.sh)"
bash tools/demo.sh --out build/demo-figures
for fig in fig1 fig4a fig4b; do test -s "build/demo-figures/$fig.svg"; done
done_with build/demo build/demo-figures

# Every unit, integration and CLI test runs once, in the sanitizer build: a
# plain debug run of the same tests would find nothing more and cost a build.
step "asan+ubsan build + tests"
cmake --preset asan-ubsan >/dev/null
cmake --build --preset asan-ubsan
# Label tree: checks of the source tree, the kernel module build and the
# aarch64 cross build, whose outcome does not depend on this build's flags
# (they run once, in the debug stage below).
ctest --preset asan-ubsan -LE tree
done_with build/asan-ubsan

# The debug build: what the sanitizer build cannot run or would only slow
# down: the real-kernel test bed (its guest runs uninstrumented binaries), the
# benchmarks' smoke runs (the sanitizer preset has no benchmarks) and the tree
# checks. Only the targets they use are built.
step "debug build: test bed, bench smoke runs, tree checks"
cmake --preset dev >/dev/null
cmake --build --preset dev --target vm_testbed_programs contego-bench-task \
  contego-kernel-floor core_bench monitor_bench sched_bench check_insns audit_days tasks_scale
# vm.booted_guest needs the package: it runs after the package stage below;
# the arm64 bed (label arm64) is the last stage.
ctest --preset dev -L 'vm|bench|tree' -E '^vm\.booted_guest$' -LE arm64

step "tsan build + monitor, supervisor and gate tests"
cmake --preset tsan >/dev/null
cmake --build --preset tsan --target supervisor_test monitor_test policy_e2e_test gate_test \
  seccomp_filter_test identity_test monitor_reading_test readings_test reload_race_test
ctest --preset tsan -L 'monitor|supervisor|gate'
done_with build/tsan

if [[ -f fuzz/CMakeLists.txt ]]; then
  step "fuzz smoke runs (clang, libFuzzer)"
  cmake --preset fuzz >/dev/null
  cmake --build --preset fuzz --target fuzzers
  # Each fuzzer replays its corpus, then mutates for 5 s: a smoke run (CI's
  # budget); CONTEGO_FUZZ_SECONDS=600 for a real campaign.
  bash tools/fuzz_smoke.sh build/fuzz "${CONTEGO_FUZZ_SECONDS:-5}"
  done_with build/fuzz
fi

# The amd64 Debian package, built and checked (docs/packaging.md); the arm64
# one is `tools/package.sh --arch arm64`, as long again, not run here.
step "amd64 Debian package"
bash tools/package.sh --arch amd64
done_with build/package  # the packages are in out/packages

# The package installed, used, stopped, restarted, removed and purged in a
# booted Debian 12 guest with the README's Install commands, and contego-dkms
# with its "Install the kernel client" commands (docs/testbed.md).
step "booted Debian guest"
debs=(out/packages/contego_*_amd64.deb)
dkms_debs=(out/packages/contego-dkms_*_all.deb)
CONTEGO_DEB=$PWD/${debs[-1]} CONTEGO_DKMS_DEB=$PWD/${dkms_debs[-1]} \
  ctest --preset dev -R '^vm\.booted_guest$' -V

# Last, the arm64 test bed (docs/testbed.md): the arm64 build (cross-compiled,
# preset arm64-test) and its seccomp filter, core, monitor and supervisor
# tests on Debian's arm64 kernel in qemu-system-aarch64, then the
# real-adapter scenarios and contego.ko there. The lists are CI's budget: the
# rover's other client pairings run on amd64, and so does the policy
# compiler's test (host-side code whose images the core tests load on arm64)
# (`ctest --preset dev -L arm64` alone runs every test and scenario). The cross tools and arm64 libraries
# come from Debian's archive; without them the test would only skip.
step "arm64 test bed"
bash tools/bootstrap.sh --cross-arm64
export CONTEGO_ARM64_TESTS="${CONTEGO_ARM64_TESTS:-seccomp_filter_test core_test monitor_test supervisor_test}"
# The supervisor tests' clients over the plain socket transport are the
# channel's and the in-process ones' code on another wire, nothing of the
# architecture's: they run on amd64 only (a quarter of the guest's time).
export CONTEGO_ARM64_GTEST_FILTER="${CONTEGO_ARM64_GTEST_FILTER-"-*/seccomp_socket"}"
export CONTEGO_ARM64_SCENARIOS="${CONTEGO_ARM64_SCENARIOS:-00-adapter,01-kernel-facilities,02-test-suite,10-arm-embedded,11-arm-monitor,21-rover-smbus2-monitor,40-start-failures,60-kernel-module,61-plain-i2c,66-kunit}"
# The guest's console goes to the test's log; its summary comes here. Here a
# skip is a failure: the step above installed everything the bed needs.
arm64_log=build/dev/tests/vm/arm64-ctest.log
rc=0
ctest --preset dev -L arm64 -E '^vm\.booted_guest_arm64$' -V >"$arm64_log" 2>&1 || rc=$?
grep -aE '^[0-9]+: (arm64\.sh:|kernel fetch|VM-(BOOTED|RESULT|DONE)|VM-CHECK (FAIL|SKIP)|VM TEST BED)' "$arm64_log" || true
if ((rc != 0)) || ! grep -aq 'VM TEST BED PASSED' "$arm64_log"; then
  tail -n 80 "$arm64_log"
  echo "arm64 test bed failed or did not run (log: $arm64_log)" >&2
  exit 1
fi

# Opt-in (CONTEGO_BOOTED_ARM64=1): the arm64 package built and installed in
# the arm64 booted guest, as on amd64 above (docs/testbed.md, "The booted
# Debian guest on arm64"). Too long for CI's budget under TCG, so not run by
# default; here a skip is a failure.
if [[ ${CONTEGO_BOOTED_ARM64:-} == 1 ]]; then
  step "arm64 Debian package + booted arm64 guest"
  bash tools/package.sh --arch arm64
  debs=(out/packages/contego_*_arm64.deb)
  booted_log=build/dev/tests/vm/booted-arm64-ctest.log
  rc=0
  CONTEGO_ARM64_DEB=$PWD/${debs[-1]} CONTEGO_DKMS_DEB=$PWD/${dkms_debs[-1]} \
    ctest --preset dev -R '^vm\.booted_guest_arm64$' -V >"$booted_log" 2>&1 || rc=$?
  grep -aE '^[0-9]+: (booted\.sh:|accel:|kernel |VM-(BOOTED|RESULT)|VM-CHECK|BOOTED GUEST|SKIPPED)' "$booted_log" || true
  if ((rc != 0)) || ! grep -aq 'BOOTED GUEST PASSED' "$booted_log"; then
    tail -n 80 "$booted_log"
    echo "arm64 booted guest failed or did not run (log: $booted_log)" >&2
    exit 1
  fi
fi

report_times
step "all tests passed"
