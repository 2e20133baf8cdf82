#!/usr/bin/env bash
# The trusted core's machine instructions per check, counted by callgrind
# inside contego_check only (--toggle-collect): the same command as the test
# bed's kernel bench (arm_init writes ALL_LED_OFF_H = 0 on the PCA9685 of
# policies/arm.policy, allowed), a plain register write (MODE2), and the
# first command from a process bound to no task (refused). Two runs of N and 11·N checks, differenced, so that the
# first checks' cold paths do not count. Exit 77 without valgrind. MAX, if
# given, bounds each row in turn (comma-separated): a row above fails.
# Usage: bench/check_insns.sh CONTEGO CHECK_INSNS POLICIES_DIR [MAX,MAX,...]
set -euo pipefail
contego=${1:?usage: check_insns.sh CONTEGO CHECK_INSNS POLICIES_DIR [MAX,...]}
check_insns=${2:?}
policies=${3:?}
IFS=, read -r -a bounds <<<"${4:-}"
rows=0
command -v valgrind >/dev/null || { echo "SKIP: valgrind not installed (tools/bootstrap.sh)"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$contego" check "$policies/arm.policy" --emit "$work/arm.img" >/dev/null

# count TASK BYTES N: instructions inside contego_check for N checks
count() {
  local out="$work/cg.$1.$2.$3"
  valgrind --tool=callgrind --toggle-collect=contego_check --callgrind-out-file="$out" \
    "$check_insns" "$work/arm.img" "$1" 1 0x40 "$2" "$3" >"$work/run.$1.$2.$3" 2>/dev/null
  awk '/^totals:/ { print $2 }' "$out"
}
row() {  # row LABEL TASK BYTES EXPECT
  local small=1000 large=11000 a b
  a=$(count "$2" "$3" $small)
  b=$(count "$2" "$3" $large)
  grep -q "last=$4" "$work/run.$2.$3.$large" || {
    echo "FAIL: $1: expected $4, got: $(cat "$work/run.$2.$3.$large")"
    exit 1
  }
  local max=${bounds[$rows]:-}
  rows=$((rows + 1))
  awk -v a="$a" -v b="$b" -v n=$((large - small)) -v l="$1" -v max="$max" \
    'BEGIN { v = (b - a) / n; printf "%-44s %8.0f instructions per check\n", l, v
             if (max != "" && v > max + 0) { printf "FAIL: %s: above %d\n", l, max; exit 1 } }'
}
echo "trusted core, machine instructions per check (callgrind, inside contego_check):"
# ALL_LED_OFF_H is the PCA9685's broadcast: the check updates the shadow of
# all 16 channels. MODE2 is one register under one invariant.
row "arm_init ALL_LED_OFF_H=0 (allow)" 0 fd00 allow
# The same broadcast alternating OFF_H 0x00 / 0x10 (full off): every check
# changes all 17 registers, so each is journaled (undo) on the way.
row "arm_init ALL_LED_OFF_H=0x00/0x10 (allow)" 0 fd00,fd10 allow
row "arm_init MODE2=0x04 (allow)" 0 0104 allow
row "ALL_LED_OFF_H=0, no task (reject)" 0xFFFF fd00 reject
echo ok
