#!/usr/bin/env python3
"""Static solves on the loading path against the full load at once.

    benchmarks/loading_path.py --rodmesh build/apps/rodmesh [--baseline OLD_RODMESH]
                               [--out benchmarks/results] [--repeat 3]

Runs `rodmesh simulate` (default flags) on the shipped examples, the hat of
docs/meshing.md and the hard cases of docs/model.md ("The loading path"),
with the current binary and, when given, an older one (the full load at once,
continuation only when Newton fails). Per scene and binary: exit status,
archive status, wall time (median of --repeat runs), Newton iterations and
load steps (summed over poses, from the progress lines), largest
displacement and out-of-plane displacement, stability and critical points
(current binary). Writes loading_path.md and loading_path.csv.
"""
import argparse
import csv
import json
import math
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def machine():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def hex_patch(exe, work, force, z_share, spatial):
    """The in-plane sheared 3x3 hexagonal patch of docs/model.md."""
    raw = os.path.join(work, "patch_raw.json")
    subprocess.run([exe, "mesh", "--grid", "hex", "--size", "0.1", "0.096", "--cells", "3", "3",
                    "--rod-vertices", "11", "--radius", "0.0005", "--radius-bounds", "0.0001", "0.001",
                    "--fix-side", "left", "--pull", "right", "0", str(force), str(z_share * force),
                    "--design", "none", "-q", "-o", raw], check=True)
    s = json.load(open(raw))
    p = s["poses"][0]
    p["clamped"] = [{"vertex": f["vertex"]} for f in p.pop("fixed")]
    if spatial:
        s["effects"] = ["stretch", "bend", "twist", "connections"]
    return s


def rod(n, length, radius, direction, E=1e8, nu=0.4, rho=500.0):
    verts = [[length * i / (n - 1) * d for d in direction] for i in range(n)]
    return {"format": "rodmesh-scene/1",
            "material": {"young_modulus": E, "poisson_ratio": nu, "density": rho},
            "vertices": verts, "rods": [{"vertices": list(range(n))}], "radius": radius, "poses": []}


def column(factor):
    E, r, L = 1e8, 0.01, 1.0
    ei = E * math.pi * r ** 4 / 4
    P = factor * math.pi ** 2 * ei / (4 * L * L)
    s = rod(51, L, [r, r], [0, 0, 1], E=E)
    s["normals"] = [[1, 0, 0]] * 51
    s["poses"] = [{"name": "column", "clamped": [{"vertex": 0}], "forces": [{"vertex": 50, "force": [0, 0, -P]}]}]
    return s


def flat_cantilever():
    E, nu, L, rt, rn = 1e7, 0.4, 0.1, 0.01, 0.001
    G = E / (2 * (1 + nu))
    eiy = E * math.pi * rt * rn ** 3 / 4
    gj = G * math.pi * rt ** 3 * rn ** 3 / (rt ** 2 + rn ** 2)
    P = 2 * 4.013 * math.sqrt(eiy * gj) / L ** 2
    s = rod(41, L, [rt, rn], [1, 0, 0], E=E, nu=nu, rho=1000.0)
    s["normals"] = [[0, 0, 1]] * 41
    s["effects"] = ["stretch", "bend", "twist"]
    s["poses"] = [{"name": "tip", "clamped": [{"vertex": 0}], "forces": [{"vertex": 40, "force": [0, -P, 0]}]}]
    return s


def arch(P):
    n, span, rise = 41, 1.0, 0.05
    R = (span * span / 4 + rise * rise) / (2 * rise)
    half = math.asin(span / 2 / R)
    verts = []
    for i in range(n):
        a = -half + 2 * half * i / (n - 1)
        verts.append([R * math.sin(a), 0, R * math.cos(a) - (R - rise)])
    return {"format": "rodmesh-scene/1", "material": {"young_modulus": 1e8, "poisson_ratio": 0.4, "density": 500.0},
            "vertices": verts, "rods": [{"vertices": list(range(n))}], "radius": [0.005, 0.005],
            "effects": ["stretch", "bend"],
            "poses": [{"name": "crown", "fixed": [{"vertex": 0}, {"vertex": n - 1}],
                       "forces": [{"vertex": n // 2, "force": [0, 0, -P]}]}]}


def scenes(exe, work):
    out = []
    for name in ("cantilever", "sheet", "sphere_gravity"):
        out.append((name, os.path.join(ROOT, "examples", name + ".json")))
    hat = os.path.join(work, "hat.json")
    subprocess.run([exe, "mesh", os.path.join(ROOT, "examples/surfaces/hat.obj"), "--cells", "60", "--pose",
                    os.path.join(ROOT, "examples/surfaces/hat_front_down.obj"), "--gravity", "0", "0", "-9.81",
                    "--fix-box", "-1", "-1", "-0.01", "1", "1", "0.001", "-q", "-o", hat], check=True)
    out.append(("hat (docs/meshing.md)", hat))
    generated = [
        ("sheared patch 0.2 load, 3D", hex_patch(exe, work, 0.2 * 0.0177, 0.0, True)),
        ("sheared patch full load, 3D", hex_patch(exe, work, 0.0177, 0.0, True)),
        ("sheared patch full load, planar scene", hex_patch(exe, work, 0.0177, 0.0, False)),
        ("sheared patch full load, 1e-4 imperfection", hex_patch(exe, work, 0.0177, 1e-4, True)),
        ("column 0.95 Pcr", column(0.95)),
        ("column 1.1 Pcr", column(1.1)),
        ("flat cantilever 2x LTB load", flat_cantilever()),
        ("shallow arch 5 N", arch(5.0)),
    ]
    for k, (name, s) in enumerate(generated):
        path = os.path.join(work, "scene%d.json" % k)
        with open(path, "w") as f:
            json.dump(s, f)
        out.append((name, path))
    return out


def run(exe, scene, work, repeat):
    archive = os.path.join(work, "out.h5")
    times = []
    for _ in range(repeat):
        if os.path.exists(archive):
            os.remove(archive)
        t0 = time.perf_counter()
        r = subprocess.run([exe, "simulate", scene, "-o", archive], capture_output=True, text=True)
        times.append(time.perf_counter() - t0)
    row = {"exit": r.returncode, "wall_s": statistics.median(times)}
    iters = steps = 0
    for m in re.finditer(r"(\d+) Newton iterations, (\d+) load steps", r.stderr):
        iters += int(m.group(1))
        steps += int(m.group(2))
    row["iterations"], row["load_steps"] = iters, steps
    if not os.path.exists(archive):
        return row
    with h5py.File(archive, "r") as f:
        row["status"] = f.attrs["status"]
        rest = f["rest/positions"][:]
        disp = oop = 0.0
        stable, eig, crit = [], [], []
        for name in f["poses"]:
            p = f["poses"][name]
            d = p["positions"][:] - rest
            disp = max(disp, float(np.linalg.norm(d, axis=1).max()))
            # out of the plane of the rest shape when it is planar: its smallest principal axis
            c = rest - rest.mean(axis=0)
            w, v = np.linalg.eigh(c.T @ c)
            if w[0] <= 1e-12 * max(w[-1], 1e-300):
                oop = max(oop, float(np.abs(d @ v[:, 0]).max()))
            if "stable" in p.attrs:
                stable.append(int(p.attrs["stable"]))
            if "smallest_eigenvalue" in p.attrs:
                eig.append(float(p.attrs["smallest_eigenvalue"]))
            if "critical_points" in p:
                crit += ["%.4g" % x for x in p["critical_points"][:, 0]]
        row["max_disp_mm"] = disp * 1e3
        row["out_of_plane_mm"] = oop * 1e3
        row["stable"] = "/".join(map(str, stable))
        row["smallest_eig"] = " ".join("%.3g" % e for e in eig)
        row["critical_at"] = " ".join(crit)
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rodmesh", required=True)
    ap.add_argument("--baseline", default="")
    ap.add_argument("--out", default=os.path.join(ROOT, "benchmarks/results"))
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    exe = os.path.abspath(args.rodmesh)
    with tempfile.TemporaryDirectory() as work:
        rows = []
        for name, scene in scenes(exe, work):
            for label, binary in (("loading path", exe), ("full load (baseline)", args.baseline)):
                if not binary:
                    continue
                r = run(os.path.abspath(binary), scene, work, args.repeat)
                r["scene"], r["solver"] = name, label
                rows.append(r)
                print(name, label, r, file=sys.stderr)
    keys = ["scene", "solver", "exit", "status", "wall_s", "iterations", "load_steps", "max_disp_mm",
            "out_of_plane_mm", "stable", "smallest_eig", "critical_at"]
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "loading_path.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)
    with open(os.path.join(args.out, "loading_path.md"), "w") as f:
        f.write("# Statics on the loading path\n\n")
        f.write("Generated by `benchmarks/loading_path.py` on %s (2 cores), %s UTC; wall time is the median of %d "
                "runs of `rodmesh simulate` with default flags (the whole process: meshing of scenes excluded). "
                "Baseline: %s.\n\n" % (machine(), time.strftime("%Y-%m-%d %H:%M", time.gmtime()), args.repeat,
                                       args.baseline or "none"))
        f.write("| " + " | ".join(keys) + " |\n|" + "---|" * len(keys) + "\n")
        for r in rows:
            f.write("| " + " | ".join(("%.3f" % r[k]) if isinstance(r.get(k), float) else str(r.get(k, ""))
                                      for k in keys) + " |\n")


if __name__ == "__main__":
    main()
