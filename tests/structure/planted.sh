#!/usr/bin/env bash
# Plants a too-long function and a too-long file into a copy of src/ and
# expects tools/check_sizes to name each one; the unplanted copy, a function
# at the limit and a long function outside the checked folders must pass.
# Usage: planted.sh SOURCE_DIR
set -euo pipefail
src="$1"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/tools"
cp -r "$src/src" "$work/"
cp "$src/tools/check_sizes" "$work/tools/"

check() { python3 "$work/tools/check_sizes" "$work"; }

check >/dev/null || {
  echo "FAIL: the unplanted copy does not pass" >&2
  exit 1
}

function_of() {  # NAME BODY_LINES: a C++ function whose body spans BODY_LINES lines
  local name="$1" lines="$2" i
  echo "int $name(int x) {"
  for ((i = 2; i < lines; i++)); do echo "  x += $i;  // { not a brace: \"}\""; done
  echo "}"
}

plant() {  # FILE TEXT...: append to FILE (made if missing)
  local file="$1"
  shift
  mkdir -p "$(dirname "$work/$file")"
  printf '%s\n' "$@" >>"$work/$file"
}

expect_passes() {  # WHAT
  local out
  if ! out=$(check); then
    echo "FAIL: $1 was refused:" >&2
    echo "$out" >&2
    exit 1
  fi
  echo "passes as expected: $1"
}

expect_refused() {  # WHAT FILE:LINE
  local out
  if out=$(check); then
    echo "FAIL: $1 passed the check" >&2
    exit 1
  fi
  if ! grep -qF "$2:" <<<"$out"; then
    echo "FAIL: the report does not name $2:" >&2
    echo "$out" >&2
    exit 1
  fi
  echo "refused as expected: $(grep -F "$2:" <<<"$out")"
}

# A function of exactly 120 lines in a checked folder passes, one of 121 fails:
# a free function, a member function, a constructor with braced initialisers.
plant src/core/planted.cc "namespace planted {" "$(function_of at_limit 120)" "}  // namespace planted"
expect_passes "a function of 120 lines in src/core"
plant src/core/planted.cc "$(function_of too_long 121)"
expect_refused "a 121-line function in src/core" "src/core/planted.cc:123"
rm "$work/src/core/planted.cc"
plant src/monitor/planted.h "struct Planted {" "  Planted() : a_{1}, b_{2} {" \
  "$(function_of body 121 | tail -n +2)" "  int a_, b_;" "};"
expect_refused "a 121-line constructor body in src/monitor" "src/monitor/planted.h:2"
rm "$work/src/monitor/planted.h"
plant src/intercept/planted.cc "class Planted {" " public:" "  $(function_of member 121)" "};"
expect_refused "a 121-line member function in src/intercept" "src/intercept/planted.cc:3"
rm "$work/src/intercept/planted.cc"

# A long function outside src/core, src/monitor and src/intercept is not counted.
plant src/policy/planted.cc "$(function_of long_but_elsewhere 200)"
expect_passes "a 200-line function in src/policy"

# A file of 800 lines passes, one of 801 fails, in any folder of src/.
rm "$work/src/policy/planted.cc"
for ((i = 0; i < 800; i++)); do echo "// line"; done >"$work/src/policy/planted.h"
expect_passes "a file of 800 lines in src/policy"
echo "// line" >>"$work/src/policy/planted.h"
expect_refused "a file of 801 lines in src/policy" "src/policy/planted.h:1"
echo "planted.sh: every planted excess was refused"
