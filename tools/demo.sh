#!/usr/bin/env bash
# The main job: installs dependencies, builds an optimised contego, runs the demo.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/bootstrap.sh demo
# The compiler cache tools/test.sh uses, when there: a second run recompiles
# nothing that did not change.
if command -v ccache >/dev/null; then
  export CCACHE_DIR="${CCACHE_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/ccache}"
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true
  export CMAKE_C_COMPILER_LAUNCHER=ccache CMAKE_CXX_COMPILER_LAUNCHER=ccache
fi
cmake --preset demo >/dev/null
# Only what the demo needs: the contego binary, at -O2 without debug info or
# whole-program LTO (the `demo` preset; benchmarks use `release`).
cmake --build --preset demo --target contego
exec build/demo/src/cli/contego demo "$@"
