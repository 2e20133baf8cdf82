#!/usr/bin/env bash
# `contego demo` on a machine without gnuplot (the package only suggests
# it): it still runs the three case studies, writes every trace as CSV, says
# why no figure was drawn, and exits 0.
# Usage: demo_without_gnuplot.sh CONTEGO
set -euo pipefail
contego="$1"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; cat "$dir/out" 2>/dev/null; exit 1; }
mkdir "$dir/empty-path"
env PATH="$dir/empty-path" "$contego" demo --out "$dir/demo" >"$dir/out" 2>&1 || fail "exit $?"
grep -q "gnuplot is not installed" "$dir/out" || fail "no note about gnuplot"
for f in fig4a fig4b fig1; do
  [ -s "$dir/demo/$f-protected.csv" ] || fail "no $f-protected.csv"
  [ ! -e "$dir/demo/$f.png" ] || fail "$f.png without gnuplot?"
done
echo "ok"
