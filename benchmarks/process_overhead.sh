#!/bin/sh
# Whole-process overhead of `rodmesh simulate` (issue 9, item 8): the
# 1001-vertex clamped gravity cantilever of the peer comparison (E = 1e8 Pa,
# rho = 500 kg/m^3, r = 0.02 m, L = 1 m; planar, so the out-of-plane
# stability check runs).
#   ./benchmarks/process_overhead.sh [BUILD_DIR] [LABEL] [RUNS]
# Times, as medians of RUNS (default 15) runs, wall-clock and CPU time
# (user + system, from the kernel's rusage) of
#   startup   `rodmesh --version` (loading the executable and its libraries,
#             static initialisation, the command-line parser)
#   process   `rodmesh simulate SCENE -o OUT.h5 -q`
# and, inside one process, the steps of the command
# (BUILD_DIR/benchmarks/rodmesh_overhead_bench: read, model, solve,
# stability, write). Rows go to benchmarks/results/process_overhead.csv under
# LABEL (default: the current commit; rows with the same label are
# replaced) and benchmarks/results/process_overhead.md shows every label
# (its "## Notes" section, if any, is kept).
set -eu
BUILD=${1:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
case "$BUILD" in /*) ;; *) BUILD="$ROOT/$BUILD" ;; esac
LABEL=${2:-$(git -C "$ROOT" rev-parse --short HEAD)}
RUNS=${3:-15}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
/usr/bin/python3 - "$BUILD" "$LABEL" "$RUNS" "$TMP" "$ROOT/benchmarks/results" <<'PY'
import csv, json, os, platform, resource, statistics, subprocess, sys, time

build, label, runs, tmp, results = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5]
exe = os.path.join(build, "apps", "rodmesh")
bench = os.path.join(build, "benchmarks", "rodmesh_overhead_bench")

n, L = 1001, 1.0
scene = {
    "format": "rodmesh-scene/1",
    "material": {"young_modulus": 1e8, "poisson_ratio": 0.3, "density": 500.0},
    "vertices": [[L * i / (n - 1), 0.0, 0.0] for i in range(n)],
    "rods": [{"vertices": list(range(n))}],
    "radius": [0.02, 0.02],
    "gravity": [0.0, 0.0, -9.81],
    "poses": [{"name": "sag", "clamped": [{"vertex": 0}]}],
}
scene_path = os.path.join(tmp, "cantilever1001.json")
json.dump(scene, open(scene_path, "w"))
out = os.path.join(tmp, "out.h5")


def timed(args):
    """Wall-clock and CPU (user + system) milliseconds of one process."""
    t0 = time.perf_counter()
    p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit("failed: " + " ".join(args))
    return 1e3 * wall, 1e3 * (ru.ru_utime + ru.ru_stime)


rows = []
for name, args in (("startup", [exe, "--version"]), ("process", [exe, "simulate", scene_path, "-o", out, "-q"])):
    timed(args)  # warm the page cache
    w, c = zip(*(timed(args) for _ in range(runs)))
    rows.append((name, statistics.median(w), statistics.median(c)))
steps = subprocess.run([bench, scene_path, out, os.path.join(tmp, "bench.h5"), str(runs)], check=True,
                       capture_output=True, text=True).stdout
for line in steps.splitlines():
    if line.startswith("#"):
        print(line)
        continue
    name, w, c = line.split()
    rows.append((name, float(w), float(c)))

machine = "%s, %d cores, %s" % (platform.processor() or platform.machine(), os.cpu_count(), platform.platform())
try:
    for l in open("/proc/cpuinfo"):
        if l.startswith("model name"):
            machine = "%s, %d cores, %s" % (l.split(":", 1)[1].strip(), os.cpu_count(), platform.platform())
            break
except OSError:
    pass
load = os.getloadavg()[0]
date = time.strftime("%Y-%m-%d")

path = os.path.join(results, "process_overhead.csv")
fields = ["label", "date", "runs", "load", "measure", "wall_ms", "cpu_ms", "machine"]
old = []
if os.path.exists(path):
    old = [r for r in csv.DictReader(open(path)) if r["label"] != label]
new = [dict(label=label, date=date, runs=runs, load="%.1f" % load, measure=m, wall_ms="%.2f" % w, cpu_ms="%.2f" % c,
            machine=machine) for m, w, c in rows]
with open(path, "w", newline="") as f:
    wr = csv.DictWriter(f, fieldnames=fields)
    wr.writeheader()
    wr.writerows(old + new)
for m, w, c in rows:
    print("%-10s wall %8.2f ms   cpu %8.2f ms" % (m, w, c))

allrows = old + new
labels = list(dict.fromkeys(r["label"] for r in allrows))
measures = ["startup", "process", "read", "model", "solve", "stability", "write"]
what = {
    "startup": "`rodmesh --version`: executable, libraries, static initialisation",
    "process": "`rodmesh simulate` (whole process)",
    "read": "in-process: read the scene",
    "model": "in-process: network, effects, pose systems",
    "solve": "in-process: Newton from rest",
    "stability": "in-process: out-of-plane stability check",
    "write": "in-process: write the archive",
}
get = {(r["label"], r["measure"]): r for r in allrows}
md = ["# Whole-process overhead of `rodmesh simulate`", "",
      "Written by `benchmarks/process_overhead.sh BUILD LABEL RUNS`: the 1001-vertex clamped gravity",
      "cantilever (E = 1e8 Pa, rho = 500, r = 0.02 m, L = 1 m; planar, so the out-of-plane stability",
      "check runs). Medians of RUNS runs, in ms; CPU = user + system time. Wall-clock times depend on",
      "the load of the machine (1-minute load average when the label was run is given); CPU times",
      "are the figure to compare.", ""]
for l in labels:
    r0 = next(r for r in allrows if r["label"] == l)
    md.append("- `%s`: %s, %s runs, load %s, %s" % (l, r0["date"], r0["runs"], r0["load"], r0["machine"]))
md += ["", "| measure | " + " | ".join("%s wall | %s CPU" % (l, l) for l in labels) + " |",
       "|---|" + "---|---|" * len(labels)]
for m in measures:
    cells = []
    for l in labels:
        r = get.get((l, m))
        cells += [r["wall_ms"], r["cpu_ms"]] if r else ["", ""]
    md.append("| %s | %s |" % (what[m], " | ".join(cells)))
md.append("")
# Keep the hand-written part (from "## Notes" on) of an existing summary.
mdpath = os.path.join(results, "process_overhead.md")
notes = ""
if os.path.exists(mdpath):
    text = open(mdpath).read()
    if "\n## Notes" in text:
        notes = text[text.index("\n## Notes") + 1:]
open(mdpath, "w").write("\n".join(md) + ("\n" + notes if notes else ""))
PY
