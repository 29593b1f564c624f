#!/usr/bin/python3
"""How the pose weights trade the poses of one design against each other.

    /usr/bin/python3 benchmarks/other_model/pose_tradeoff.py --rodmesh BIN --scene DIR/shell_large.json \
        --work WORK [--method sand|reduced] [--weights 1,1,1 1,0.05,0.3 ...] [--reuse]

For every weight set (one weight per pose, in the scene's pose order) it
writes a copy of the scene with those weights, runs `rodmesh optimize` with
default flags, makes a scene of the archived design (`/rest/positions`,
`/design/radii`, every weight 1) and solves it with `rodmesh simulate`, and
prints one markdown row: each pose's RMS from that re-solve against the
initial design's (the archive's `/poses/NAME/initial_positions`), and the
design's RMS under equal weights, the measure a scene with equal weights
is optimized for. `--reuse` takes an archive already in WORK instead of
running the optimizer again.

The scenes come from benchmarks/other_model/make_other_model.py.
"""
import argparse
import copy
import json
import os
import subprocess
import sys
import time

import h5py
import numpy as np


def rms(a, b):
    return float(np.sqrt(((a - b) ** 2).sum(axis=1).mean()))


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode not in (0, 1):
        sys.exit("pose_tradeoff: %s exited %d: %s" % (" ".join(cmd), r.returncode, r.stderr.strip()[-400:]))
    return r.returncode


def row(rodmesh, scene, work, method, weights, reuse):
    names = [p["name"] for p in scene["poses"]]
    if len(weights) != len(names):
        sys.exit("pose_tradeoff: %d weights for %d poses" % (len(weights), len(names)))
    tag = "%s_w%s" % (method, "_".join("%g" % w for w in weights))
    s = copy.deepcopy(scene)
    for p, w in zip(s["poses"], weights):
        p["weight"] = w
    path = os.path.join(work, tag + ".json")
    with open(path, "w") as f:
        json.dump(s, f)
    out = os.path.join(work, tag + ".h5")
    wall = float("nan")
    if not (reuse and os.path.exists(out)):
        t = time.time()
        run([rodmesh, "optimize", path, "-o", out, "--method", method, "-q"])
        wall = time.time() - t
    with h5py.File(out, "r") as f:
        status = f.attrs["status"]
        status = status.decode() if isinstance(status, bytes) else str(status)
        resim = copy.deepcopy(scene)
        resim.pop("design", None)
        resim.pop("radius", None)
        resim["vertices"] = f["rest/positions"][()].tolist()
        resim["radii"] = f["design/radii"][()].tolist()
        for p in resim["poses"]:
            p["weight"] = 1.0
        archived = {n: f["poses"][n]["positions"][()] for n in names}
        target = {n: f["poses"][n]["target"][()] for n in names}
        initial = {n: f["poses"][n]["initial_positions"][()] for n in names}
    rpath = os.path.join(work, tag + ".resim.json")
    with open(rpath, "w") as f:
        json.dump(resim, f)
    rout = os.path.join(work, tag + ".resim.h5")
    run([rodmesh, "simulate", rpath, "-o", rout, "-q"])
    cells, total, gap = [], 0.0, 0.0
    with h5py.File(rout, "r") as g:
        for n in names:
            x = g["poses"][n]["positions"][()]
            e, e0 = rms(x, target[n]), rms(initial[n], target[n])
            total += e * e
            gap = max(gap, float(np.abs(x - archived[n]).max()))
            cells.append("%.4f mm, %.3fx" % (1e3 * e, e / e0))
    equal = 1e3 * np.sqrt(total / len(names))
    print("| %s | %s | %s | %s | %.4f mm | %.1e m | %s |" % (
        method, " / ".join("%g" % w for w in weights), status, " | ".join(cells), equal, gap,
        "" if wall != wall else "%.0f" % wall))
    sys.stdout.flush()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rodmesh", required=True)
    ap.add_argument("--scene", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--method", default="sand", choices=["sand", "reduced"])
    ap.add_argument("--weights", nargs="+", default=["1,1,1"])
    ap.add_argument("--reuse", action="store_true")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    with open(a.scene) as f:
        scene = json.load(f)
    names = [p["name"] for p in scene["poses"]]
    print("| method | weights (%s) | status | %s | RMS, equal weights | re-solve vs archive | wall s |" % (
        " / ".join(names), " | ".join(names)))
    print("|---|---|---|%s---|---|---|" % ("---|" * len(names)))
    for w in a.weights:
        row(a.rodmesh, scene, a.work, a.method, [float(x) for x in w.split(",")], a.reuse)


if __name__ == "__main__":
    main()
