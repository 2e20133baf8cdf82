#!/usr/bin/env bash
# How a check's cost grows with the policy (issue 40): arm.policy plus K more
# devices (regmap valves, one register each), each with an access rule, a
# rate limit of arm_init and two invariants, K = 0 .. 31 (the image's 32
# devices). Two commands are counted in each policy, by callgrind inside
# contego_check (as bench/check_insns.sh: two runs, differenced):
#   - arm_init MODE2 = 0x04 on the arm: the rules that apply stay the same
#     (few rules in a large policy);
#   - arm_init level = 40 on the last valve: its own limit and invariants.
# Prints the table and the slope of instructions per added device; a check
# should cost what its own rules cost, so the slope should be near 0.
# Exit 77 without valgrind.
# Usage: bench/scale_insns.sh CONTEGO CHECK_INSNS POLICIES_DIR [K...]
set -euo pipefail
contego=${1:?usage: scale_insns.sh CONTEGO CHECK_INSNS POLICIES_DIR [K...]}
check_insns=${2:?}
policies=${3:?}
shift 3
sizes=("$@")
((${#sizes[@]})) || sizes=(0 4 16 31)
command -v valgrind >/dev/null || { echo "SKIP: valgrind not installed (tools/bootstrap.sh)"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

policy() {  # policy K: arm.policy and K valves at 0x50.. on bus 1
  cat "$policies/arm.policy"
  local i
  for ((i = 1; i <= $1; i++)); do
    cat <<P
device v$i : regmap at i2c-1 $(printf '0x%02x' $((0x4f + i))) { register 0x01 level : u8 range 0..100 }
allow arm_init -> v$i
limit arm_init -> v$i.level 60000 per job else ignore
invariant V${i}_LOW on v$i.level: require value <= 80 else ignore
invariant V${i}_EVEN on v$i.level: require value % 2 == 0 else ignore
P
  done
}
count() {  # count IMAGE ADDR BYTES N: instructions inside contego_check for N checks
  local out="$work/cg"
  valgrind --tool=callgrind --toggle-collect=contego_check --callgrind-out-file="$out" \
    "$check_insns" "$1" 0 1 "$2" "$3" "$4" >"$work/run" 2>/dev/null
  grep -q "last=allow" "$work/run" || { echo "FAIL: $2 $3: $(cat "$work/run")" >&2; return 1; }
  awk '/^totals:/ { print $2 }' "$out"
}
per_check() {  # per_check IMAGE ADDR BYTES
  local a b
  a=$(count "$1" "$2" "$3" 200)
  b=$(count "$1" "$2" "$3" 2200)
  echo $(((b - a) / 2000))
}
printf '%-8s %-7s %-11s %-22s %-22s\n' devices rates invariants "MODE2 on the arm" "level on the last valve"
rows=()
for k in "${sizes[@]}"; do
  policy "$k" >"$work/p.policy"
  "$contego" check "$work/p.policy" --emit "$work/p.img" >"$work/check.out" 2>&1 ||
    { echo "FAIL: the policy with $k valves does not compile"; cat "$work/check.out"; exit 1; }
  arm=$(per_check "$work/p.img" 0x40 0104)
  valve=-
  ((k == 0)) || valve=$(per_check "$work/p.img" "$(printf '0x%02x' $((0x4f + k)))" 0128)
  printf '%-8s %-7s %-11s %-22s %-22s\n' $((k + 1)) $((5 + k)) $((7 + 2 * k)) "$arm" "$valve"
  rows+=("$k $arm")
done
# Least-squares slope of the arm's command against K: instructions per device added.
printf '%s\n' "${rows[@]}" | awk '{ n++; sx += $1; sy += $2; sxx += $1 * $1; sxy += $1 * $2 }
  END { d = n * sxx - sx * sx; s = d ? (n * sxy - sx * sy) / d : 0
        printf "slope: %.1f instructions per added device for a command whose rules did not change\n", s
        # Counted, not timed: the same binary gives the same count. More
        # than a few instructions per device means a loop over the whole
        # policy came back into the check.
        if (s > 5) { print "FAIL: the check grows with the policy"; exit 1 } }'
echo ok
