#!/usr/bin/env bash
# expect_exit.sh STATUS TEXT COMMAND...: passes only if COMMAND exits with
# STATUS (not a crash, not success) and its output contains TEXT.
set -u
want="$1"
text="$2"
shift 2
out="$("$@" 2>&1)"
rc=$?
printf '%s\n' "$out"
if [[ "$rc" != "$want" ]]; then
  echo "expected exit status $want, got $rc" >&2
  exit 1
fi
if ! grep -qF -- "$text" <<<"$out"; then
  echo "expected the output to contain: $text" >&2
  exit 1
fi
