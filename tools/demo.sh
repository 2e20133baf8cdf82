#!/usr/bin/env bash
# The main job: installs dependencies, builds an optimised contego, runs the demo.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/bootstrap.sh
cmake --preset release >/dev/null
cmake --build --preset release
exec build/release/src/cli/contego demo "$@"
