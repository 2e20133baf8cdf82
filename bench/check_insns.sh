#!/usr/bin/env bash
# The trusted core's machine instructions per check, counted by callgrind
# inside contego_check only (--toggle-collect): the same command as the test
# bed's kernel bench (arm_init writes ALL_LED_OFF_H = 0 on the PCA9685 of
# policies/arm.policy, allowed), and the same command from a process bound to
# no task (refused). Two runs of N and 11·N checks, differenced, so that the
# first checks' cold paths do not count. Exit 77 without valgrind.
# Usage: bench/check_insns.sh CONTEGO CHECK_INSNS POLICIES_DIR
set -euo pipefail
contego=${1:?usage: check_insns.sh CONTEGO CHECK_INSNS POLICIES_DIR}
check_insns=${2:?}
policies=${3:?}
command -v valgrind >/dev/null || { echo "SKIP: valgrind not installed (tools/bootstrap.sh)"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$contego" check "$policies/arm.policy" --emit "$work/arm.img" >/dev/null

# count TASK N: instructions inside contego_check for N checks
count() {
  local out="$work/cg.$1.$2"
  valgrind --tool=callgrind --toggle-collect=contego_check --callgrind-out-file="$out" \
    "$check_insns" "$work/arm.img" "$1" 1 0x40 fd00 "$2" >"$work/run.$1.$2" 2>/dev/null
  awk '/^totals:/ { print $2 }' "$out"
}
row() {  # row LABEL TASK EXPECT
  local small=1000 large=11000 a b
  a=$(count "$2" $small)
  b=$(count "$2" $large)
  grep -q "last=$3" "$work/run.$2.$large" || {
    echo "FAIL: $1: expected $3, got: $(cat "$work/run.$2.$large")"
    exit 1
  }
  awk -v a="$a" -v b="$b" -v n=$((large - small)) -v l="$1" \
    'BEGIN { printf "%-44s %8.0f instructions per check\n", l, (b - a) / n }'
}
echo "trusted core, machine instructions per check (callgrind, inside contego_check):"
row "arm_init ALL_LED_OFF_H=0 (allow)" 0 allow
row "same write, no task (reject)" 0xFFFF reject
echo ok
