#!/usr/bin/python3
"""Scenes for the default-flags benchmark (benchmarks/defaults/README.md).

    /usr/bin/python3 benchmarks/defaults/make_cases.py --rodmesh BIN --out DIR [--only a,b]

writes DIR/CASE.json (rodmesh-scene/1, with a `design` block) for each case,
DIR/CASE.hidden.json (the hidden design's scene that made the targets, where
there is one) and DIR/cases.json (per case: vertices, poses, parameters, the
hidden design's radius range and largest rest displacement, and the RMS of the
initial design's equilibria against the targets).

  small_radii   hex sheet (~230 vertices, 3 poses); targets from a hidden
                design inside the design space: radii only
  small_rest    the same sheet; hidden rest displacement only (radii = the
                initial 2 mm), design parameters ["rest_shape"]
  small_both    the same sheet; hidden radii and rest displacement
  sheet_unreachable  benchmarks/study/make_scenes.py `make_sheet` (693
                vertices, 4 opposing poses from different sections: not
                exactly reachable)
  hat_radii     the hat (`rodmesh mesh examples/surfaces/hat.obj --cells 60`,
                ~1700 vertices) with the four poses of make_scenes.py
                `make_hat(with_rest_pose=False)`, all targets from ONE hidden
                design inside the design space: radii only
  hat_both      the same with a hidden rest displacement too

The hidden designs are given per control point of the design space
(control_points_per_rod = 4, Bernstein control values at arc fractions j/3,
shared ends; docs/optimization.md "Design space") and mapped to the vertices
by benchmarks/study/sweeps_scenes.py `apply_design`, so every target is
exactly reachable (except sheet_unreachable's). The control values are
sweeps_scenes.py `hidden_design` evaluated at the control points' rest
positions (normalised over the whole scene), its radii stretched linearly to
the case's range and its (vertical) rest displacement scaled to the case's
largest value.

Every target simulation must converge (the archive's per-pose status);
otherwise the script stops with exit status 1 naming the case and pose.
"""
import argparse
import json
import math
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "benchmarks", "study"))
import make_scenes as M  # noqa: E402
import sweeps_scenes as S  # noqa: E402

N_CONTROL = 4
INITIAL_RADIUS = (0.002, 0.002)

# The small sheet: 4 x 4 hex cells, 5 vertices per rod (211 vertices, 56 rods), 25 mm rods (sweeps_scenes.hex_sheet).
SMALL_CELLS, SMALL_K = (4, 4), 5
SMALL_LOADS = S.POSE_LOADS[:3]  # 0.15 N right; 0.02 N up; 0.1 N right + 0.1 N sideways
SMALL_BOUNDS = (0.001, 0.005)
SMALL_RADII = (0.0012, 0.004)   # hidden radii stretched to this range (m)
SMALL_DISP = 0.004              # largest hidden rest displacement (m, out of plane)
HAT_RADII = (0.0012, 0.0028)
HAT_DISP = 0.004


def control_point_positions(scene, n=N_CONTROL):
    """Per rod, the rest positions (n x 3) of its control points at arc fractions j/(n-1)."""
    V = np.asarray(scene["vertices"], float)
    out = []
    for rod in scene["rods"]:
        s = S.rod_arc_fractions(V, rod)
        P = V[rod["vertices"]]
        c = np.linspace(0.0, 1.0, n)
        out.append(np.stack([np.interp(c, s, P[:, k]) for k in range(3)], 1))
    return out


def hidden_polys(scene, radii_range, disp_max, vary_radii=True, vary_rest=True):
    """Control polygons (per rod: n x 2 radii, n x 3 displacements) of the hidden design."""
    V = np.asarray(scene["vertices"], float)
    cps = control_point_positions(scene)
    allp = np.concatenate([V] + cps)
    r, d = S.hidden_design(allp)   # normalised over the scene's extent, vertices included
    r, d = r[len(V):], d[len(V):]
    if vary_radii:
        lo, hi = r.min(0), r.max(0)
        r = radii_range[0] + (radii_range[1] - radii_range[0]) * (r - lo) / np.maximum(hi - lo, 1e-15)
    else:
        r = np.tile(INITIAL_RADIUS, (len(r), 1))
    if vary_rest:
        d = d * (disp_max / max(np.abs(d).max(), 1e-15))
    else:
        d = np.zeros_like(d)
    polys, i = [], 0
    for c in cps:
        polys.append((r[i:i + len(c)], d[i:i + len(c)]))
        i += len(c)
    return polys


def rms(targets, positions):
    s, n = 0.0, 0
    for name, t in targets.items():
        q = np.asarray(positions[name])
        s += float(((q - np.asarray(t)) ** 2).sum())
        n += len(q)
    return math.sqrt(s / n)


def positions_of(res):
    return {n: q for n, (q, _) in res.items()}


def initial_rms(rodmesh, scene, tmp, tag):
    """RMS (m) of the initial design's equilibria against the scene's targets."""
    s = dict(scene)
    s.pop("design", None)
    q = positions_of(M.simulate(rodmesh, s, tmp, tag + "_initial"))
    return rms({p["name"]: p["target"] for p in scene["poses"]}, q)


def retarget(rodmesh, base, tmp, tag, radii_range, disp_max, parameters):
    """`base` (poses without targets needed, its vertices the rest shape of the
    initial design) with every pose's target the equilibrium of one hidden
    design inside the design space; returns (scene, hidden scene, hidden info)."""
    vary_radii, vary_rest = "radii" in parameters, "rest_shape" in parameters
    polys = hidden_polys(base, radii_range, disp_max, vary_radii, vary_rest)
    radii, rest = S.apply_design(polys, base)
    hid = dict(base)
    hid.pop("design", None)
    hid.pop("radius", None)
    hid["vertices"] = rest.tolist()
    hid["radii"] = radii.tolist()
    hid["poses"] = [{k: v for k, v in p.items() if k != "target"} for p in base["poses"]]
    q = positions_of(M.simulate(rodmesh, hid, tmp, tag + "_hidden"))
    out = dict(base)
    out.pop("radii", None)
    out["radius"] = list(INITIAL_RADIUS)
    out["poses"] = [dict(p, target=np.asarray(q[p["name"]]).tolist()) for p in hid["poses"]]
    bounds = base.get("design", {}).get("radius_bounds", list(SMALL_BOUNDS))
    out["design"] = dict(parameters=list(parameters), radius_bounds=list(bounds), control_points_per_rod=N_CONTROL)
    disp = np.linalg.norm(rest - np.asarray(base["vertices"], float), axis=1)
    info = dict(hidden_radii_mm=[round(1e3 * float(radii.min()), 3), round(1e3 * float(radii.max()), 3)],
                hidden_max_rest_displacement_mm=round(1e3 * float(disp.max()), 3))
    return out, hid, info


_small_base = {}


def small_base(rodmesh, tmp):
    if "s" not in _small_base:
        s = S.hex_sheet(rodmesh, os.path.join(tmp, "small_base.json"), SMALL_CELLS, SMALL_K, pulls=SMALL_LOADS)
        s.pop("design", None)
        _small_base["s"] = s
    return _small_base["s"]


def make_small(parameters):
    def make(rodmesh, tmp):
        base = dict(small_base(rodmesh, tmp))
        base["design"] = dict(radius_bounds=list(SMALL_BOUNDS))
        return retarget(rodmesh, base, tmp, "small", SMALL_RADII, SMALL_DISP, parameters)
    return make


_hat_base = {}


def hat_base(rodmesh, tmp):
    """make_scenes.make_hat's scene and four poses (its targets are replaced)."""
    if "s" not in _hat_base:
        scene, _ = M.make_hat(rodmesh, tmp, with_rest_pose=False)
        _hat_base["s"] = scene
    return _hat_base["s"]


def make_hat(parameters):
    def make(rodmesh, tmp):
        return retarget(rodmesh, dict(hat_base(rodmesh, tmp)), tmp, "hat", HAT_RADII, HAT_DISP, parameters)
    return make


def make_unreachable(rodmesh, tmp):
    scene, _ = M.make_sheet(rodmesh, tmp)
    return scene, None, dict(note="make_scenes.make_sheet: 4 poses from 4 different uniform sections")


CASES = {
    "small_radii": make_small(["radii"]),
    "small_rest": make_small(["rest_shape"]),
    "small_both": make_small(["radii", "rest_shape"]),
    "sheet_unreachable": make_unreachable,
    "hat_radii": make_hat(["radii"]),
    "hat_both": make_hat(["radii", "rest_shape"]),
}


def write_json(path, obj, **kw):
    with open(path + ".tmp", "w") as f:
        json.dump(obj, f, **kw)
    os.replace(path + ".tmp", path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rodmesh", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--only", default=",".join(CASES))
    a = ap.parse_args()
    names = [n for n in a.only.split(",") if n]
    bad = [n for n in names if n not in CASES]
    if bad:
        print("make_cases.py: --only: unknown case(s) %s (known: %s)" % (", ".join(bad), ", ".join(CASES)),
              file=sys.stderr)
        return 2
    rodmesh = os.path.abspath(a.rodmesh)
    os.makedirs(a.out, exist_ok=True)
    summary_path = os.path.join(a.out, "cases.json")
    summary = json.load(open(summary_path)) if os.path.exists(summary_path) else {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in names:
            try:
                scene, hidden, info = CASES[n](rodmesh, tmp)
                r0 = initial_rms(rodmesh, scene, tmp, n)
            except M.Failure as e:
                print("make_cases.py: %s: %s" % (n, e), file=sys.stderr)
                return 1
            write_json(os.path.join(a.out, n + ".json"), scene)
            if hidden is not None:
                write_json(os.path.join(a.out, n + ".hidden.json"), hidden)
            c = M.counts(scene)
            rec = dict(c, poses=[p["name"] for p in scene["poses"]], parameters=scene["design"]["parameters"],
                       radius_bounds=scene["design"]["radius_bounds"], initial_rms_mm=round(1e3 * r0, 4), **info)
            summary[n] = rec
            print("%s: %d vertices, %d rods, %d connections, %d poses, parameters %s, initial RMS %.3f mm%s" % (
                n, c["nodes"], c["rods"], c["connections"], len(scene["poses"]), "+".join(rec["parameters"]),
                1e3 * r0, "" if hidden is None else "; hidden radii %.2f-%.2f mm, rest displacement up to %.2f mm" % (
                    tuple(info["hidden_radii_mm"]) + (info["hidden_max_rest_displacement_mm"],))), flush=True)
            if r0 < 1e-3:
                print("make_cases.py: warning: %s: initial RMS %.3f mm is below 1 mm" % (n, 1e3 * r0), file=sys.stderr)
            write_json(summary_path, summary, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
