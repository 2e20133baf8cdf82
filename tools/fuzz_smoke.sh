#!/usr/bin/env bash
# Runs every libFuzzer binary of a fuzz build briefly, starting from its seed
# corpus (copied, so the checked-in corpus is not modified).
# Usage: tools/fuzz_smoke.sh BUILD_DIR [SECONDS_PER_TARGET]
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:?usage: tools/fuzz_smoke.sh BUILD_DIR [SECONDS]}"
seconds="${2:-10}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
found=0
while IFS= read -r fuzzer; do
  name="$(basename "$fuzzer" _fuzzer)"
  found=1
  mkdir -p "$work/$name"
  if [[ -d "fuzz/corpus/$name" ]]; then cp -r "fuzz/corpus/$name/." "$work/$name/"; fi
  printf '== %s (%ss)\n' "$name" "$seconds"
  # A fixed seed keeps the gate reproducible; longer, seeded-at-random runs
  # are for hunting (CONTEGO_FUZZ_SEED=0 lets libFuzzer pick).
  log="$work/$name.log"
  status=0
  "$fuzzer" -seed="${CONTEGO_FUZZ_SEED:-1}" -max_total_time="$seconds" -print_final_stats=1 \
    "$work/$name" >"$log" 2>&1 || status=$?
  tail -n 12 "$log"
  ((status == 0)) || exit "$status"
  # A fuzzer that sees the coverage of its own file alone mutates blind: the
  # libraries it feeds must be instrumented too (CONTEGO_FUZZ in CMakeLists.txt;
  # the smallest fuzzer here has about 1,500 counters, one file about 100).
  counters="$(sed -n 's/.*(\([0-9]*\) inline 8-bit counters).*/\1/p' "$log" | head -n 1)"
  if ((${counters:-0} < 1000)); then
    echo "$name: ${counters:-no} coverage counters: the code it fuzzes is not instrumented" >&2
    exit 1
  fi
done < <(find "$build" -type f -name '*_fuzzer' -perm -u+x | sort)
if ((found == 0)); then
  echo "no fuzzers found under $build" >&2
  exit 1
fi
