#!/usr/bin/env python3
"""SAND against the reduced-space method on one design scene.

Runs `rodmesh optimize` once per (method, schedule), one after another, and
prints a Markdown table read from the archives: RMS of the initial and final
designs (re-solved from rest), wall time, time in model evaluations and in
the optimizer, iterations, peak memory, status; plus a CSV of RMS against
time (from /history) for plotting.

    /usr/bin/python3 benchmarks/design_compare.py build/apps/rodmesh SCENE.json OUT_DIR \
        [--runs sand:paper,sand:joint,reduced:paper] [--max-iter 2000]
"""
import argparse
import csv
import os
import subprocess
import sys
import time

import h5py
import numpy as np


def rms(f, key):
    s, n = 0.0, 0
    for name in f["poses"]:
        p = f["poses"][name]
        q = p[key][()]
        t = p["target"][()]
        s += float(((q - t) ** 2).sum())
        n += q.shape[0]
    return (s / n) ** 0.5


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("rodmesh")
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--runs", default="sand:paper,sand:joint,reduced:paper")
    ap.add_argument("--max-iter", default="2000")
    ap.add_argument("--reuse", action="store_true", help="read existing archives in OUT_DIR instead of running")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rows = []
    with open(os.path.join(a.out, "history.csv"), "w", newline="") as hf:
        hw = csv.writer(hf)
        hw.writerow(["method", "schedule", "iteration", "time_s", "rms_mm", "constraint_violation_N"])
        for run in a.runs.split(","):
            method, schedule = run.split(":")
            out = os.path.join(a.out, f"{method}_{schedule}.h5")
            log = os.path.join(a.out, f"{method}_{schedule}.log")
            t0 = time.time()
            if a.reuse and os.path.exists(out):
                code = 0
            else:
                with open(log, "w") as lf:
                    code = subprocess.call([a.rodmesh, "optimize", a.scene, "-o", out, "--method", method,
                                            "--schedule", schedule, "--max-iter", a.max_iter], stderr=lf, stdout=lf)
            wall = time.time() - t0
            if code not in (0, 1):
                print(f"{run}: exit {code}, see {log}", file=sys.stderr)
                continue
            with h5py.File(out, "r") as f:
                h = f["history"]
                for i, t, r, v in zip(h["iteration"][()], h["time_s"][()], h["rms_error"][()],
                                      h["constraint_violation"][()]):
                    hw.writerow([method, schedule, int(i), float(t), 1e3 * float(r), float(v)])
                rows.append({
                    "run": f"{method} / {schedule}",
                    "initial": 1e3 * rms(f, "initial_positions"),
                    "final": 1e3 * rms(f, "positions"),
                    "time": float(f.attrs["time_s"]),
                    "eval": float(f.attrs.get("evaluation_time_s", np.nan)),
                    "solver": float(f.attrs.get("solver_time_s", np.nan)),
                    "iters": int(f.attrs["iterations"]),
                    "mem": float(f.attrs.get("peak_memory_bytes", 0)) / 2**20,
                    "status": f.attrs["status"].decode() if isinstance(f.attrs["status"], bytes)
                    else str(f.attrs["status"]),
                    "wall": wall,
                })
    print("| run | RMS initial (mm) | RMS final (mm) | ratio | optimizer time (s) | in evaluations (s) | "
          "in optimizer (s) | iterations | peak memory (MiB) | status |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['run']} | {r['initial']:.3f} | {r['final']:.3f} | {r['initial'] / r['final']:.1f}x | "
              f"{r['time']:.1f} | {r['eval']:.1f} | {r['solver']:.1f} | {r['iters']} | {r['mem']:.0f} | "
              f"{r['status']} |")


if __name__ == "__main__":
    main()
