#!/usr/bin/env bash
# The test bed on arm64 (CTest vm.testbed_arm64): cross-builds contego, its
# preload client, the bench client and the test binaries the guest runs with
# the arm64-test preset (the package-arm64 build with its tests), then boots
# Debian's arm64 kernel in qemu-system-aarch64 once (run.sh --arch arm64):
#   01  seccomp_filter_test on the real arm64 kernel (aarch64 numbers)
#   02  core, policy, monitor, readings, bus, gate and supervisor tests (the
#       seccomp supervisor and the preload client against the virtual bus,
#       with the real i2c-tools and python3 clients)
#   10-40  the real-adapter scenarios, as on amd64 (i2c-stub cross-built)
# Exits 77 (CTest: skipped) with the reason when QEMU's aarch64 emulator or
# a cross tool is missing (bash tools/bootstrap.sh --cross-arm64).
#
# Usage: tests/vm/arm64.sh [--build-dir DIR] [--workdir DIR] [run.sh options...]
#   default build dir build/arm64-test, workdir DIR/tests/vm/arm64
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
build=$src/build/arm64-test workdir="" extra=()
while (($#)); do
  case "$1" in
    # Absolute: the test binaries name their data (the preload client, the
    # attack programs) by absolute paths, which the guest mirrors.
    --build-dir) build=$(realpath -m "$2"); shift 2 ;;
    --workdir) workdir=$2; shift 2 ;;
    *) extra+=("$1"); shift ;;
  esac
done
[[ -n "$workdir" ]] || workdir=$build/tests/vm/arm64

skip() { echo "VM TEST BED SKIPPED: $*"; exit 77; }
for tool in qemu-system-aarch64 aarch64-linux-gnu-g++ aarch64-linux-gnu-gcc qemu-aarch64 mmdebstrap; do
  command -v $tool >/dev/null || skip "$tool not found (bash tools/bootstrap.sh --cross-arm64)"
done
for lib in libfmt-dev libssl-dev libseccomp-dev libsystemd-dev; do
  dpkg-query -W -f='${Status}' "$lib:arm64" 2>/dev/null | grep -q 'install ok installed' ||
    skip "$lib:arm64 not installed (bash tools/bootstrap.sh --cross-arm64)"
done

# The test binaries the guest runs (scenarios 01 and 02). Tests of the
# host's own facilities (CLI scripts, docs, fuzz corpora, perf) stay on amd64.
# CONTEGO_ARM64_TESTS (names, space-separated) narrows the list.
tests=(seccomp_filter_test core_test policy_test monitor_test readings_test bus_test gate_test
  supervisor_test policy_e2e_test identity_test monitor_reading_test)
if [[ -n "${CONTEGO_ARM64_TESTS:-}" ]]; then read -r -a tests <<<"$CONTEGO_ARM64_TESTS"; fi
t0=$SECONDS
# From the source tree: CTest runs this script in the build tree, where
# there are no presets.
(cd "$src" && cmake --preset arm64-test -B "$build" >/dev/null)
# The attack programs of scenario 61 too: only some test binaries depend on them.
attacks=(attack_rdwr_race attack_pid_reuse attack_static attack_signal_storm attack_rdwr_atomic
  attack_identity attack_msg_flags)
cmake --build "$build" --target contego contego_preload vm_i2c_write_loop "${tests[@]}" \
  "${attacks[@]}" -- -j2
echo "arm64.sh: cross build $((SECONDS - t0))s"

# Every scenario but the tools ones (30, 31: about two minutes each of
# wall-clock holds that test the monitor's budget, not the architecture;
# run on amd64) and the benches (50, 63: TCG's emulated arm64 times nothing
# real): the CI budget. --scenarios all (or a list) overrides.
# CONTEGO_ARM64_SCENARIOS (comma-separated names) chooses them instead.
scenarios=$(cd "$here/guest/scenarios" && ls ./*.sh | sed 's,^\./,,; s,\.sh$,,' |
  grep -v -e '^30-' -e '^31-' -e '^50-' -e '^63-' | paste -sd,)
scenarios=${CONTEGO_ARM64_SCENARIOS:-$scenarios}
# The guest's whole run under TCG: 6.5 min on a loaded 2-core host; the
# CTest's own limit is 40 min.
# CONTEGO_ARM64_GTEST_FILTER: GTEST_FILTER for those binaries in the guest.
[[ -z "${CONTEGO_ARM64_GTEST_FILTER:-}" ]] || extra=(--gtest-filter "$CONTEGO_ARM64_GTEST_FILTER" "${extra[@]}")
args=(--arch arm64 --skip-code 77 --workdir "$workdir" --scenarios "$scenarios"
  --timeout "${CONTEGO_VM_TIMEOUT:-2100}"
  --contego "$build/src/cli/contego"
  --bench-client "$build/tests/vm/i2c-write-loop")
for t in "${tests[@]}"; do
  f=$(find "$build" -name "$t" -type f -perm -u+x | head -n1)
  [[ -n "$f" ]] || { echo "arm64.sh: $t was not built" >&2; exit 1; }
  args+=(--test-binary "$f")
done
# What the supervisor tests name at compile time: the attack programs and
# the preload client in the build tree, the client scripts and the example
# policies in the source tree.
args+=(--mirror "$build/src/intercept/preload/libcontego_preload.so" --mirror "$src/tests/intercept/scripts"
  --mirror "$src/policies")
for f in "$build"/tests/intercept/attack_*; do
  [[ -x "$f" && -f "$f" ]] && args+=(--mirror "$f" --attack-binary "$f")
done
exec bash "$here/run.sh" "${args[@]}" "${extra[@]}"
