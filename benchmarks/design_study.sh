#!/usr/bin/env bash
# The design study (issue 10): the paper's four experiments (Sheet, Hat, Dino,
# Smiley) rebuilt as scenes, optimized with SAND, the reduced method (BFGS) and reduced Newton-CG,
# and reported as Markdown + CSV + PNG naming the machine and the commit.
#
#   benchmarks/design_study.sh [--quick] [--reuse] [--rodmesh BIN] [--work DIR]
#                              [--time-limit S] [--experiments sheet,hat,dino,smiley]
#
#   --quick        every optimizer run limited to 40 s (the whole command takes
#                  ~10 min on a loaded 2-core machine, sweeps.py --quick aside);
#                  results in benchmarks/results/design_study_quick{.md,/}
#   (default)      every optimizer run limited to 600 s (at most 2 h for the
#                  twelve runs: each method with its default schedule); results in benchmarks/results/design_study{.md,/}
#   --reuse        keep archives made with the same binary, scene and limits
#                  (resume an interrupted study; regenerate the report only)
#   --work DIR     scenes and archives (default build/design_study[_quick])
#
# Steps: benchmarks/study/make_scenes.py (scenes), run_study.py (optimize runs,
# one thread each, one after another), sweeps.py if present (its own
# sweeps.md is included), report.py (tables, plots, pictures via
# scripts/render.py). Needs a built rodmesh (scripts/build.sh) and Debian's
# python3-h5py, python3-numpy, python3-matplotlib.
set -euo pipefail
cd "$(dirname "$0")/.."

quick=0
reuse=()
bin=build/apps/rodmesh
work=""
limit=""
experiments=sheet,hat,dino,smiley
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --reuse) reuse=(--reuse) ;;
    --rodmesh) bin="$2"; shift ;;
    --work) work="$2"; shift ;;
    --time-limit) limit="$2"; shift ;;
    --experiments) experiments="$2"; shift ;;
    -h|--help) sed -n '2,22p' "$0"; exit 0 ;;
    *) echo "design_study.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done

if [ "$quick" = 1 ]; then
  name=design_study_quick; limit=${limit:-40}; quickflag=(--quick)
  title="Design study, quick run (40 s per optimizer run)"
else
  name=design_study; limit=${limit:-600}; quickflag=()
  title="Design study: the paper's four experiments, SAND, reduced BFGS and reduced Newton-CG"
fi
work=${work:-build/$name}
results=benchmarks/results
assets=$results/$name
py=/usr/bin/python3
export MPLBACKEND=Agg OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1

if [ ! -x "$bin" ]; then
  echo "design_study.sh: no rodmesh executable at '$bin' (build it first: scripts/build.sh)" >&2
  exit 2
fi
mkdir -p "$work" "$assets"
start=$(date +%s)

if [ "${#reuse[@]}" -eq 0 ] || [ ! -f "$work/scenes/scenes.json" ]; then
  echo "== scenes ($work/scenes)"
  "$py" benchmarks/study/make_scenes.py --rodmesh "$bin" --out "$work/scenes" --only "$experiments"
fi

echo "== optimizer runs ($work/runs, time limit ${limit} s each)"
status=0
"$py" benchmarks/study/run_study.py --rodmesh "$bin" --scenes "$work/scenes" --out "$work/runs" \
  --experiments "$experiments" --time-limit "$limit" "${reuse[@]}" || status=$?

if [ -f benchmarks/study/sweeps.py ]; then
  echo "== sweeps (benchmarks/study/sweeps.py)"
  "$py" benchmarks/study/sweeps.py --rodmesh "$bin" --out "$assets" "${quickflag[@]}" || status=$?
fi

echo "== report ($results/$name.md)"
notes=()
[ -f "benchmarks/study/${name}_notes.md" ] && notes=(--notes "benchmarks/study/${name}_notes.md")
"$py" benchmarks/study/report.py --scenes "$work/scenes" --runs "$work/runs" --assets "$assets" \
  --md "$results/$name.md" --title "$title" --command "benchmarks/design_study.sh${quickflag[*]:+ ${quickflag[*]}}" "${notes[@]}"
echo "design study done in $(( $(date +%s) - start )) s (exit $status)"
exit $status
