#!/usr/bin/env bash
# Plants includes a layer may not make into a copy of the tree and expects
# tools/check_layers to name each one; the unplanted copy must pass.
# Usage: planted.sh SOURCE_DIR
set -euo pipefail
src="$1"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/tools"
cp -r "$src/src" "$src/include" "$work/"
cp "$src/tools/check_layers" "$work/tools/"

python3 "$work/tools/check_layers" "$work" >/dev/null || {
  echo "FAIL: the unplanted copy does not pass" >&2
  exit 1
}

expect_refused() {  # FILE INCLUDE: plant INCLUDE on FILE's first line, expect it named
  local file="$1" include="$2" out
  cp "$work/$file" "$work/$file.orig"
  { echo "#include \"$include\""; cat "$work/$file.orig"; } >"$work/$file"
  if out=$(python3 "$work/tools/check_layers" "$work"); then
    echo "FAIL: $file including $include passed the check" >&2
    exit 1
  fi
  if ! grep -qF "$file:1: layer" <<<"$out"; then
    echo "FAIL: the report does not name $file:1:" >&2
    echo "$out" >&2
    exit 1
  fi
  echo "refused as expected: $(grep -F "$file:1:" <<<"$out")"
  mv "$work/$file.orig" "$work/$file"
}

expect_refused src/core/checker.cc monitor/monitor.h           # core reaches up to the host
expect_refused include/contego/core/checker.h image/image_model.h  # public API to a host layer
expect_refused src/bus/virtual_bus.cc monitor/monitor.h        # a lower layer reaches up
expect_refused src/policy/lex/lex.cc policy/check/check.h       # a phase reaches a later phase
expect_refused src/sched/analysis.cc policy/compile.h           # sideways, between unrelated layers

# A folder that no layer names is reported too.
mkdir -p "$work/src/newlayer"
echo '#include "base/result.h"' >"$work/src/newlayer/x.cc"
if python3 "$work/tools/check_layers" "$work" >/dev/null; then
  echo "FAIL: a file in a folder of no layer passed" >&2
  exit 1
fi
echo "planted.sh: every planted include was refused"
