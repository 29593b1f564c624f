#!/usr/bin/python3
"""Acceptance-style runner for the scenes of make_sweep.py.

    /usr/bin/python3 benchmarks/sweep/run_sweep.py --rodmesh BIN --cases DIR --runs DIR [--only a,b] [--budget-min 75]

Per case, one rodmesh process at a time, DEFAULT flags:
  timeout -s INT 600 rodmesh optimize CASE.json -o runs/CASE.opt.h5
  rodmesh simulate CASE.json -o runs/CASE.sim.h5
  rodmesh simulate runs/CASE.resim.json -o runs/CASE.resim.h5   (archived design, no design block)
Writes runs/results.json (one record per case) and runs/CASE.{opt,sim,resim}.log.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import time

import h5py
import numpy as np

BIN = "rodmesh"
CASES = "cases"
RUNS = "runs"


def astr(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def run(cmd, log, timeout=None):
    t0 = time.perf_counter()
    with open(log, "w") as lf:
        p = subprocess.run(cmd, stdout=lf, stderr=subprocess.STDOUT)
    return p.returncode, time.perf_counter() - t0


def tail(log, n=6):
    lines = [l.rstrip() for l in open(log, errors="replace") if l.strip()]
    return lines[-n:]


def warnings(log):
    pat = re.compile(r"warn|imperfect|loading path|gap|critical|unstable|not converge|fail|back.?off|fallback|nan|inf\b|error",
                     re.I)
    out = []
    for l in open(log, errors="replace"):
        l = l.rstrip()
        if pat.search(l) and not l.startswith("iter "):
            out.append(l)
    return out


def nonfinite(path):
    bad = []
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind == "f":
                a = obj[()]
                if not np.all(np.isfinite(a)):
                    if name.endswith("confirmed_rms") or name.endswith("trust_radius"):
                        return
                    bad.append("%s (%d non-finite)" % (name, int(np.size(a) - np.isfinite(a).sum())))
            for k, v in obj.attrs.items():
                if isinstance(v, (float, np.floating)) and not math.isfinite(v):
                    bad.append("%s@%s=%r" % (name, k, v))
        f.visititems(visit)
        for k, v in f.attrs.items():
            if isinstance(v, (float, np.floating)) and not math.isfinite(v):
                bad.append("/@%s=%r" % (k, v))
    return bad


def rms(pos, tgt):
    s, n = 0.0, 0
    for k in tgt:
        s += float(((pos[k] - tgt[k]) ** 2).sum())
        n += len(tgt[k])
    return math.sqrt(s / n)


def pose_info(path, names):
    out = {}
    with h5py.File(path, "r") as f:
        root = {k: (astr(v) if isinstance(v, (bytes, str)) else (v.item() if hasattr(v, "item") else v))
                for k, v in f.attrs.items()}
        for n in names:
            g = f["poses"][n]
            a = {k: (astr(v) if isinstance(v, (bytes, str)) else (v.item() if hasattr(v, "item") and np.size(v) == 1 else None))
                 for k, v in g.attrs.items()}
            a["positions"] = g["positions"][()]
            if "initial_positions" in g:
                a["initial_positions"] = g["initial_positions"][()]
            if "critical_points" in g:
                a["critical_points"] = g["critical_points"][()].tolist()
            out[n] = a
        rest = f["rest/positions"][()]
        radii = f["design/radii"][()]
    return root, out, rest, radii


def one(name, a):
    scene_path = os.path.join(CASES, name + ".json")
    scene = json.load(open(scene_path))
    names = [p["name"] for p in scene["poses"]]
    tgt = {p["name"]: np.asarray(p["target"], float) for p in scene["poses"]}
    rec = dict(case=name, vertices=len(scene["vertices"]), poses=len(names),
               parameters="+".join(scene["design"]["parameters"]))
    # optimize, default flags
    out = os.path.join(RUNS, name + ".opt.h5")
    log = os.path.join(RUNS, name + ".opt.log")
    if os.path.exists(out):
        os.remove(out)
    cmd = ["timeout", "-s", "INT", "600", BIN, "optimize", scene_path, "-o", out]
    print("[%s] %s" % (time.strftime("%H:%M:%S"), " ".join(cmd)), flush=True)
    rc, wall = run(cmd, log)
    rec.update(opt_exit=rc, opt_wall_s=round(wall, 2), opt_tail=tail(log), opt_warnings=warnings(log)[-15:])
    if os.path.exists(out):
        root, P, rest, radii = pose_info(out, names)
        rec.update(opt_status=root.get("status"), opt_message=root.get("message"), method=root.get("method"),
                   iterations=root.get("iterations"), archived_design=root.get("archived_design"),
                   effects_note=root.get("effects_note"), opt_time_s=root.get("time_s"),
                   eq_gap_tol=root.get("equilibrium_gap_tolerance"))
        rec["pose_attrs"] = {n: {k: v for k, v in P[n].items() if k not in ("positions", "initial_positions")}
                             for n in names}
        rec["nonfinite"] = nonfinite(out)
        if all("initial_positions" in P[n] for n in names):
            rec["initial_rms_mm"] = 1e3 * rms({n: P[n]["initial_positions"] for n in names}, tgt)
        apos = {n: P[n]["positions"] for n in names}
        rec["archived_rms_mm"] = 1e3 * rms(apos, tgt)
        ra = [P[n].get("rms_error") for n in names]
        if all(r is not None for r in ra):
            rec["archived_rms_attr_mm"] = 1e3 * math.sqrt(sum(r * r for r in ra) / len(ra))
        rec["radii_range_mm"] = [1e3 * float(radii.min()), 1e3 * float(radii.max())]
        rec["rest_disp_max_mm"] = 1e3 * float(np.linalg.norm(rest - np.asarray(scene["vertices"]), axis=1).max())
        # re-simulate the archived design
        s = dict(scene)
        s.pop("design", None)
        s.pop("radius", None)
        s["vertices"] = rest.tolist()
        s["radii"] = radii.tolist()
        rp = os.path.join(RUNS, name + ".resim.json")
        json.dump(s, open(rp, "w"))
        ro = rp[:-5] + ".h5"
        if os.path.exists(ro):
            os.remove(ro)
        rl = os.path.join(RUNS, name + ".resim.log")
        rc2, w2 = run([BIN, "simulate", rp, "-o", ro], rl)
        rec.update(resim_exit=rc2, resim_wall_s=round(w2, 2), resim_tail=tail(rl, 4), resim_warnings=warnings(rl)[-10:])
        if os.path.exists(ro):
            r2, P2, _, _ = pose_info(ro, names)
            rec["resim_status"] = {n: P2[n].get("status") for n in names}
            rec["resim_message"] = r2.get("message")
            rec["resim_effects_note"] = r2.get("effects_note")
            spos = {n: P2[n]["positions"] for n in names}
            rec["resim_rms_mm"] = 1e3 * rms(spos, tgt)
            diff = max(float(np.linalg.norm(spos[n] - apos[n], axis=1).max()) for n in names)
            rec["resim_max_diff_mm"] = 1e3 * diff
            ext = float(np.linalg.norm(np.ptp(np.asarray(scene["vertices"]), axis=0)))
            rec["resim_rel_diff"] = diff / ext
            rec["resim_nonfinite"] = nonfinite(ro)
    else:
        rec["opt_status"] = "no archive"
    # simulate original scene, default flags
    so = os.path.join(RUNS, name + ".sim.h5")
    sl = os.path.join(RUNS, name + ".sim.log")
    if os.path.exists(so):
        os.remove(so)
    rc3, w3 = run([BIN, "simulate", scene_path, "-o", so], sl)
    rec.update(sim_exit=rc3, sim_wall_s=round(w3, 2), sim_tail=tail(sl, 4), sim_warnings=warnings(sl)[-10:])
    if os.path.exists(so):
        r3, P3, _, _ = pose_info(so, names)
        rec["sim_status"] = {n: P3[n].get("status") for n in names}
        rec["sim_rms_mm"] = 1e3 * rms({n: P3[n]["positions"] for n in names}, tgt)
        rec["sim_message"] = r3.get("message")
        rec["sim_nonfinite"] = nonfinite(so)
        if "initial_positions" in (P if os.path.exists(out) else {}).get(names[0], {}):
            rec["sim_vs_initial_mm"] = 1e3 * max(float(np.linalg.norm(P3[n]["positions"] - P[n]["initial_positions"], axis=1).max())
                                                  for n in names)
    print("    opt exit %s %.1fs status %s; RMS init %s -> arch %s -> resim %s (diff %s mm); sim exit %s %.1fs" % (
        rec["opt_exit"], rec["opt_wall_s"], rec.get("opt_status"), fmt(rec.get("initial_rms_mm")),
        fmt(rec.get("archived_rms_mm")), fmt(rec.get("resim_rms_mm")), fmt(rec.get("resim_max_diff_mm")),
        rec["sim_exit"], rec["sim_wall_s"]), flush=True)
    return rec


def fmt(x):
    return "-" if x is None else "%.4g" % x


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rodmesh", required=True)
    ap.add_argument("--cases", required=True)
    ap.add_argument("--runs", required=True)
    ap.add_argument("--only", default="")
    ap.add_argument("--budget-min", type=float, default=75)
    a = ap.parse_args()
    global BIN, CASES, RUNS
    BIN, CASES, RUNS = os.path.abspath(a.rodmesh), os.path.abspath(a.cases), os.path.abspath(a.runs)
    os.makedirs(RUNS, exist_ok=True)
    idx = json.load(open(os.path.join(CASES, "cases.json")))
    names = [n for n in a.only.split(",") if n] or list(idx)
    resp = os.path.join(RUNS, "results.json")
    results = json.load(open(resp)) if os.path.exists(resp) else {}
    t0 = time.time()
    for n in names:
        if time.time() - t0 > 60 * a.budget_min:
            print("budget exhausted, skipping", n, flush=True)
            continue
        results[n] = one(n, a)
        json.dump(results, open(resp, "w"), indent=1, default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
