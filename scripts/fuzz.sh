#!/usr/bin/env bash
# Fuzzes the readers of untrusted files for N minutes each (default 10):
#   scene    the scene reader (JSON text)
#   surface  the OBJ, OFF and PLY readers
#   archive  the archive reader of `inspect` and `export` (HDF5 file images)
#   optimize the checks of `optimize` before any work: flags and design block
# Builds the libFuzzer harnesses of fuzz/ with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer into build-fuzz/, seeds each corpus from
# examples/, tests/ and fuzz/regressions/, runs the targets one after the
# other (nice'd, one process each) and prints executions and findings per
# target. Findings of the last run are in build-fuzz/findings/TARGET/; once understood
# and fixed, copy them to fuzz/regressions/TARGET/ (tests/io/fuzz_regression_test.cc
# and tests/meshing/surface_fuzz_regression_test.cc run them through the
# normal readers in the default test suite).
#
#   scripts/fuzz.sh [MINUTES] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
minutes="${1:-10}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(scene surface archive optimize)
case "$minutes" in
  '' | *[!0-9]*) echo "usage: scripts/fuzz.sh [MINUTES] [scene|surface|archive|optimize ...]" >&2; exit 2 ;;
esac

./scripts/install-deps.sh
build=build-fuzz
CC=clang CXX=clang++ cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRODMESH_FUZZ=ON \
  -DRODMESH_BUILD_TESTS=OFF -DRODMESH_BUILD_MESHING=OFF -DRODMESH_NATIVE=OFF >/dev/null
nice cmake --build "$build" -j1 --target fuzz_scene fuzz_surface fuzz_archive fuzz_optimize make_seed_archives

# Seeds: every scene and surface of the repository, small hand-made OFF and
# PLY files (ASCII and binary), archives shaped like those of simulate,
# optimize and dynamic runs, and every regression input.
seeds="$build/seeds"
rm -rf "$seeds"
mkdir -p "$seeds/scene" "$seeds/surface" "$seeds/archive" "$seeds/optimize"
for f in examples/*.json tests/cli/*.json; do cp "$f" "$seeds/scene/$(echo "$f" | tr / _)"; done
# fuzz_optimize: a line of flags, then a scene with a design block.
k=0
for flags in "--max-iter 50 --time-limit 5" "--tol 1e-6 --threads 2" "--max-iter 1e12 --time-limit -1e-9" \
  "--tol 1e300 --max-iter ''"; do
  for f in tests/cli/optimize_small.json examples/*.json; do
    if grep -q '"design"' "$f"; then
      { echo "$flags"; cat "$f"; } >"$seeds/optimize/seed_${k}_$(basename "$f")"
    fi
  done
  k=$((k + 1))
done
cp examples/surfaces/*.obj "$seeds/surface/"
printf 'OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n' >"$seeds/surface/square.off"
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' >"$seeds/surface/triangle.ply"
{
  printf 'ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n'
  /usr/bin/python3 -c 'import struct,sys; sys.stdout.buffer.write(struct.pack("<9dB3I", 0,0,0, 1,0,0, 0,1,0, 3, 0,1,2))'
} >"$seeds/surface/triangle_binary.ply"
"$build/fuzz/make_seed_archives" "$seeds/archive" examples/cantilever.json tests/cli/bent_3d.json \
  tests/cli/optimize_small.json >/dev/null
for t in scene surface archive optimize; do
  if [ -d "fuzz/regressions/$t" ]; then cp "fuzz/regressions/$t/"* "$seeds/$t/"; fi
done

summary=()
for t in "${targets[@]}"; do
  exe="$build/fuzz/fuzz_$t"
  [ -x "$exe" ] || { echo "fuzz.sh: unknown target '$t' (scene, surface, archive, optimize)" >&2; exit 2; }
  corpus="$build/corpus/$t"
  findings="$build/findings/$t"
  log="$build/fuzz_$t.log"
  rm -rf "$findings"  # the summary counts this run's findings; the corpus grows from run to run
  mkdir -p "$corpus" "$findings"
  extra=()
  [ "$t" = scene ] && extra+=(-dict=fuzz/scene.dict)
  [ "$t" = optimize ] && extra+=(-dict=fuzz/scene.dict)
  # HDF5 itself leaks on some error paths; leaks in our code show up in the
  # scene and surface targets, which share the io library.
  [ "$t" = archive ] && extra+=(-detect_leaks=0)
  echo "== fuzz_$t: $minutes min (log $log)"
  # -fork=1: a crash or a timeout is recorded and fuzzing goes on, so that one
  # run finds every problem, and the executions add up over the whole time.
  nice "$exe" "$corpus" "$seeds/$t" -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
    -max_total_time=$((minutes * 60)) -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
    -artifact_prefix="$findings/" "${extra[@]}" >"$log" 2>&1 || true
  execs=$(grep -oE '#[0-9]+' "$log" | tail -1 | tr -d '#')
  crashes=$(find "$findings" -name 'crash-*' | wc -l)
  timeouts=$(find "$findings" -name 'timeout-*' | wc -l)
  ooms=$(find "$findings" -name 'oom-*' | wc -l)
  summary+=("$(printf '%-8s %4s min  %12s executions  %3s crashes  %3s timeouts  %3s out-of-memory  corpus %s' \
    "$t" "$minutes" "${execs:-0}" "$crashes" "$timeouts" "$ooms" "$(ls "$corpus" | wc -l)")")
done
echo
echo "fuzz.sh summary (findings in $build/findings/):"
printf '  %s\n' "${summary[@]}"
