#!/usr/bin/env bash
# Benchmark of the meshing pipeline on the hat-sized example (paper: 116
# connections, 1727 nodes): time to mesh the surface (CVT, geodesic rods,
# two target poses) and to export the printable solid.
#
#   benchmarks/meshing_bench.sh [RODMESH_BINARY] [RUNS]
#
# Writes benchmarks/results/meshing.csv (one row per run and step) and
# benchmarks/results/meshing.md (summary naming the machine). `simulate` is run
# once only to produce the archive that `export` needs; it is not timed here.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
bin="${1:-/work/build-meshing/apps/rodmesh}"
runs="${2:-3}"
surf="$root/examples/surfaces"
out="$here/results"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"
[ -f "$surf/hat.obj" ] || /usr/bin/python3 "$root/examples/make_surfaces.py" "$surf" > /dev/null

mesh_args=("$surf/hat.obj" -o "$work/hat.json" --cells 60
           --pose "$surf/hat_front_down.obj" --pose "$surf/hat_lean_left.obj"
           --fix-box -1 -1 -0.01 1 1 0.001)

now() { date +%s.%N; }
csv="$out/meshing.csv"
echo "run,step,seconds,detail" > "$csv"
"$bin" -q mesh "${mesh_args[@]}"
"$bin" -q simulate "$work/hat.json" -o "$work/hat.h5" || true   # exit 1 (not converged) still writes the archive
for i in $(seq 1 "$runs"); do
  t0=$(now); "$bin" mesh "${mesh_args[@]}" 2> "$work/mesh.log"; t1=$(now)
  echo "$i,mesh,$(printf "%.3f" "$(echo "$t1 - $t0" | bc)"),\"$(grep '^rod mesh' "$work/mesh.log")\"" >> "$csv"
  t0=$(now); "$bin" export "$work/hat.h5" -o "$work/hat.stl" 2> "$work/export.log"; t1=$(now)
  echo "$i,export,$(printf "%.3f" "$(echo "$t1 - $t0" | bc)"),\"$(grep '^solid' "$work/export.log")\"" >> "$csv"
done

median() { sort -n | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
mesh_med=$(awk -F, '$2=="mesh"{print $3}' "$csv" | median)
export_med=$(awk -F, '$2=="export"{print $3}' "$csv" | median)
cpu=$(lscpu | sed -n 's/^Model name:[[:space:]]*//p' | head -1)
stl_mb=$(du -m "$work/hat.stl" | cut -f1)
{
  echo "# Meshing benchmark: hat example"
  echo
  echo "Machine: $cpu, $(nproc) cores; $(date -u +%Y-%m-%d). Command: \`benchmarks/meshing_bench.sh\` ($runs runs, median)."
  echo
  echo "Input: \`examples/surfaces/hat.obj\` (769 vertices, 1488 faces, 0.23 m), \`--cells 60\`, two poses, rim fixed."
  echo
  echo "| step | median wall time (s) |"
  echo "|---|---|"
  echo "| mesh (CVT, geodesic rods, targets, scene written) | $mesh_med |"
  echo "| export (sweep, contour, CGAL checks, STL written) | $export_med |"
  echo
  echo "Mesh report:"
  echo
  echo '```'
  cat "$work/mesh.log"
  echo '```'
  echo
  echo "Export report (STL: ${stl_mb} MB):"
  echo
  echo '```'
  cat "$work/export.log"
  echo '```'
} > "$out/meshing.md"
cat "$out/meshing.md"
