#!/usr/bin/env bash
# Installs, builds and runs the main job on the bundled example: the static
# equilibrium of every pose of examples/cantilever.json, then a summary.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build.sh
./build/apps/rodmesh simulate examples/cantilever.json -o cantilever.h5
./build/apps/rodmesh inspect cantilever.h5
