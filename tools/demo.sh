#!/usr/bin/env bash
# The main job: installs dependencies, builds an optimised contego, runs the demo.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/bootstrap.sh demo
cmake --preset release >/dev/null
# Only what the demo needs: the contego binary (every test and benchmark
# target is `cmake --build --preset release`).
cmake --build --preset release --target contego
exec build/release/src/cli/contego demo "$@"
