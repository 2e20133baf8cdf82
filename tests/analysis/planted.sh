#!/usr/bin/env bash
# Takes the lock out of guarded accesses in a copy of the tree and expects
# clang's thread-safety analysis to refuse each one; the unplanted copy must
# pass. (Without this, annotations that expand to nothing would pass too.)
# Usage: planted.sh SOURCE_DIR
set -euo pipefail
src="$1"
command -v clang++ >/dev/null || { echo "SKIP: clang++ is not installed"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp -r "$src/src" "$src/include" "$work/"

analyse() {  # FILE: the analysis of one translation unit of the copy
  clang++ -std=c++20 -I"$work/include" -I"$work/src" -fsyntax-only -Wthread-safety \
    -Werror=thread-safety "$work/$1" 2>&1
}

expect_refused() {  # FILE FUNCTION FIELD: drop the lock FUNCTION takes, expect FIELD named
  local file="$1" function="$2" field="$3" out
  analyse "$file" >/dev/null || { echo "FAIL: the unplanted $file does not pass" >&2; exit 1; }
  cp "$work/$file" "$work/$file.orig"
  # The first `base::MutexLock` line after the function's definition starts.
  awk -v f="$function" '
    index($0, f) == 1 { in_f = 1 }
    in_f && /base::MutexLock lock\(mu_\);/ { in_f = 0; next }
    { print }' "$work/$file.orig" >"$work/$file"
  if cmp -s "$work/$file" "$work/$file.orig"; then
    echo "FAIL: no lock of $function found to take out of $file" >&2
    exit 1
  fi
  if out=$(analyse "$file"); then
    echo "FAIL: $function without its lock passed the analysis" >&2
    exit 1
  fi
  if ! grep -q "variable '$field' requires holding mutex" <<<"$out"; then
    echo "FAIL: the analysis of $function without its lock does not name $field" >&2
    echo "$out" >&2
    exit 1
  fi
  mv "$work/$file.orig" "$work/$file"
  echo "refused: $function without its lock ($field)"
}

expect_refused src/bus/virtual_bus.cc "uint64_t VirtualBus::operations()" operations_
expect_refused src/monitor/monitor.cc "void Monitor::set_complain(" complain_
expect_refused src/gate/socket_client.cc "void SocketClient::job_boundary(" broken_
