#!/bin/sh
# Hat-sized network benchmark: Newton against dynamic relaxation.
#   ./benchmarks/network_bench.sh [BUILD_DIR] [extra rodmesh_network_bench flags]
# Generates the hat scenes with `rodmesh mesh` into a temporary directory and
# writes benchmarks/results/network.{md,csv} and network_history.csv.
set -eu
BUILD=${1:-build}
[ $# -gt 0 ] && shift
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
MESH="$BUILD/apps/rodmesh mesh examples/surfaces/hat.obj --cells 60 --pose examples/surfaces/hat_front_down.obj --gravity 0 0 -9.81 -q"
# The hat as in docs/meshing.md: the whole brim held.
$MESH -o "$TMP/hat.json" --fix-box -1 -1 -0.01 1 1 0.001
# Variant: the brim held at its back only (x < -0.08 m), more unknowns.
$MESH -o "$TMP/hat_back.json" --fix-box -1 -1 -0.01 -0.08 1 0.001
"$BUILD/benchmarks/rodmesh_network_bench" --scene "$TMP/hat.json" --scene2 "$TMP/hat_back.json" \
  --out benchmarks/results --command "./benchmarks/network_bench.sh $BUILD" "$@"
