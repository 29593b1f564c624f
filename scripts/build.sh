#!/usr/bin/env bash
# Configures and builds rodmesh (Release) into ./build. Idempotent.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build build -j"$(nproc 2>/dev/null || echo 2)"
