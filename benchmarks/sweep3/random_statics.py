#!/usr/bin/python3
"""Acceptance sweep 3: random static scenes through `rodmesh simulate` (default flags).

    /usr/bin/python3 benchmarks/sweep3/random_statics.py [--seed 1] [--count 150]
        [--rodmesh build/apps/rodmesh] [--cases DIR] [--out DIR] [--first 0]
        [--only NAME,...] [--no-rerun] [--generate-only]

Generates --count random but valid scenes (`rodmesh-scene/1`) into --cases,
each within docs/formats.md's plausible ranges:

- sheets from `rodmesh mesh --grid hex|quad|tri` (cells 1..5 each way, 2..9
  vertices per rod, 0.02..0.5 m, --hex-rows, --fit), flat or made a shell
  (smooth z bump, cylindrical curvature about x or y, a saddle), sometimes
  with short "tab" rods sticking out of the boundary (free ends);
- a single rod (straight, arched, helical) or two / three rods joined at one
  vertex (a star, straight or curved arms);
- material E 1e5..5e9 Pa, nu 0..0.49, density 100..8000 kg/m^3; radius
  [r_t, r_n] 0.2..5 mm, sometimes elliptic (ratio up to 5), sometimes per
  vertex `radii` varying along the structure;
- supports: held (`fixed` without position) or clamped sides / ends, a side
  prescribed by a rigid motion (translation up to 40% of the size, rotation
  up to 90 degrees), point forces (log-uniform 1e-4..1e3 x EI/L^2, in and
  out of plane), twisting moments at free ends, gravity (scene-wide, random
  direction) on or off; 1..3 poses;
- about 12% deliberately under-constrained scenes (nothing held, only
  gravity; a single pinned vertex; a mechanism): these may fail legitimately
  and are counted separately.

Then runs each through `rodmesh simulate SCENE -o OUT.h5` one at a time
(timeout 300 s), reads the archive with h5py (docs/formats.md) and judges:
finite positions, held vertices where prescribed (1e-9 m), positive work of
the loads for poses loaded only by forces / gravity, stability of converged
poses. Every exit-1 / crash / timeout is run once more. Writes
OUT/results.csv, OUT/results.json and OUT/summary.md.
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RODMESH = os.path.join(ROOT, "build", "apps", "rodmesh")
TIMEOUT = 300.0
SLOW = 60.0


def logu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def rand_dir(rng):
    return unit(rng.normal(size=3))


def rot(axis, ang):
    a = unit(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(ang) * K + (1 - math.cos(ang)) * K @ K


def rnd(x, n=12):
    """Round for JSON (keeps files small, values exact as written)."""
    return [float("%.*g" % (n, c)) for c in x]


# ----------------------------------------------------------------- geometry
class Geo:
    """Vertices (V x 3), rods (lists), sides {name: [vertex]}, size L, info."""

    def __init__(self, verts, rods, sides, size, info, normals=None, plane_normal=None):
        self.v = np.asarray(verts, float)
        self.rods = rods
        self.sides = sides
        self.size = size
        self.info = info
        self.normals = normals
        self.plane_normal = plane_normal  # for in/out-of-plane loads (None: 3D)

    def end_count(self):
        c = np.zeros(len(self.v), int)
        for r in self.rods:
            c[r[0]] += 1
            c[r[-1]] += 1
        return c

    def free_ends(self):
        c = self.end_count()
        return [i for i in range(len(self.v)) if c[i] == 1]

    def edge_lengths(self):
        return np.array([np.linalg.norm(self.v[r[k + 1]] - self.v[r[k]]) for r in self.rods for k in range(len(r) - 1)])


def run_mesh(rodmesh, args, path):
    r = subprocess.run([rodmesh, "mesh"] + args + ["-o", path, "-q"], capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        raise RuntimeError("mesh failed: %s %s" % (args, r.stderr))
    with open(path) as f:
        return json.load(f)


def make_sheet(rng, rodmesh, tmpdir, name):
    grid = rng.choice(["hex", "quad", "tri"])
    W, H = logu(rng, 0.02, 0.5), logu(rng, 0.02, 0.5)
    if max(W, H) / min(W, H) > 8:  # keep the aspect within reason
        H = W * rng.uniform(0.3, 3)
        H = min(max(H, 0.02), 0.5)
    nx, ny = int(rng.integers(1, 6)), int(rng.integers(1, 6))
    K = int(rng.integers(2, 10))
    fit = rng.choice(["regular", "stretch"])
    args = ["--grid", grid, "--size", "%.6g" % W, "%.6g" % H, "--cells", str(nx), str(ny), "--rod-vertices", str(K),
            "--fit", fit]
    if grid == "hex":
        rows = rng.choice(["alternate", "offset"])
        if rows == "alternate" and nx == 1 and ny >= 2:
            rows = "offset"  # mesh refuses it (exit 2, documented in its message)
        args += ["--hex-rows", rows]
    base = run_mesh(rodmesh, args, os.path.join(tmpdir, name + "_mesh.json"))
    sides = {}
    for side in ("left", "right", "bottom", "top"):
        s = run_mesh(rodmesh, args + ["--fix-side", side], os.path.join(tmpdir, name + "_side.json"))
        sides[side] = [f["vertex"] for f in s["poses"][0].get("fixed", [])]
    os.remove(os.path.join(tmpdir, name + "_side.json"))
    os.remove(os.path.join(tmpdir, name + "_mesh.json"))
    v = np.array(base["vertices"], float)
    rods = [list(r["vertices"]) for r in base["rods"]]
    ext = v.max(0) - v.min(0)
    L = float(max(ext[0], ext[1]))
    info = {"mesh": " ".join(args)}
    # optional tabs: short rods out of boundary connections (free ends)
    ntabs = int(rng.choice([0, 0, 0, 1, 2]))
    if ntabs:
        cand = sorted(set(sides["right"] + sides["top"] + sides["bottom"]))
        c = np.zeros(len(v), int)
        for r in rods:
            c[r[0]] += 1
            c[r[-1]] += 1
        cand = [i for i in cand if c[i] >= 1]
        rng.shuffle(cand)
        centre = v.mean(0)
        tabs = []
        for i in cand[:ntabs]:
            d = v[i] - centre
            d[2] = 0
            d = unit(d) if np.linalg.norm(d) > 0 else np.array([1.0, 0, 0])
            ln = L * rng.uniform(0.05, 0.3)
            nk = int(rng.integers(1, 5))
            start = len(v)
            newp = [v[i] + d * ln * (k / nk) for k in range(1, nk + 1)]
            v = np.vstack([v, newp])
            rods.append([i] + list(range(start, start + nk)))
            tabs.append(start + nk - 1)
        info["tabs"] = len(tabs)
    flat = v.copy()
    shape = rng.choice(["flat", "bump", "cylinder", "saddle"], p=[0.25, 0.3, 0.3, 0.15])
    info["shape"] = str(shape)
    normals = None
    plane_normal = np.array([0.0, 0.0, 1.0])
    cx, cy = flat[:, 0].mean(), flat[:, 1].mean()
    if shape == "bump":
        A = rng.uniform(0.03, 0.35) * L * rng.choice([-1, 1])
        sig = rng.uniform(0.2, 0.6) * L
        x0, y0 = cx + rng.uniform(-0.2, 0.2) * ext[0], cy + rng.uniform(-0.2, 0.2) * ext[1]
        dx, dy = flat[:, 0] - x0, flat[:, 1] - y0
        g = np.exp(-(dx ** 2 + dy ** 2) / (2 * sig ** 2))
        v[:, 2] = A * g
        nrm = np.stack([A * g * dx / sig ** 2, A * g * dy / sig ** 2, np.ones(len(v))], 1)
        normals = nrm / np.linalg.norm(nrm, axis=1)[:, None]
        info["shape"] = "bump A=%.3g L" % (A / L)
        plane_normal = None
    elif shape == "cylinder":
        axis = int(rng.integers(0, 2))  # 0: bend x about the y axis; 1: bend y about x
        span = ext[axis] if ext[axis] > 0 else L
        ang = rng.uniform(0.3, 2.6)  # total opening angle of the sheet
        Rc = span / ang * rng.choice([-1, 1])
        s = flat[:, axis] - (cx if axis == 0 else cy)
        th = s / Rc
        v[:, axis] = (cx if axis == 0 else cy) + Rc * np.sin(th)
        v[:, 2] = Rc * (1 - np.cos(th))
        nrm = np.zeros((len(v), 3))
        nrm[:, axis] = -np.sin(th)
        nrm[:, 2] = np.cos(th)
        normals = nrm
        info["shape"] = "cylinder axis=%s angle=%.2f rad" % ("y" if axis == 0 else "x", ang)
        plane_normal = None
    elif shape == "saddle":
        c = rng.uniform(0.3, 1.5) / L
        dx, dy = flat[:, 0] - cx, flat[:, 1] - cy
        v[:, 2] = 0.5 * c * (dx ** 2 - dy ** 2)
        nrm = np.stack([-c * dx, c * dy, np.ones(len(v))], 1)
        normals = nrm / np.linalg.norm(nrm, axis=1)[:, None]
        info["shape"] = "saddle c=%.2f/L" % (c * L)
        plane_normal = None
    # normals: flat keeps none (derived: plane), shells: analytic or derived
    if normals is not None and rng.random() < 0.5:
        normals = None
        info["normals"] = "derived"
    elif normals is not None:
        info["normals"] = "analytic"
    # rotate/translate the whole scene sometimes (not axis-aligned)
    if rng.random() < 0.3:
        Rm = rot(rand_dir(rng), rng.uniform(0, math.pi))
        off = rng.uniform(-0.5, 0.5, 3)
        v = v @ Rm.T + off
        if normals is not None:
            normals = normals @ Rm.T
        if plane_normal is not None:
            plane_normal = Rm @ plane_normal
        info["rigid"] = "rotated"
    return Geo(v, rods, sides, L, info, normals, plane_normal), grid


def make_rod(rng):
    kind = rng.choice(["straight", "arch", "helix"], p=[0.25, 0.35, 0.4])
    L = logu(rng, 0.02, 0.5)
    n = int(rng.integers(4, 61))
    s = np.linspace(0, 1, n + 1)
    info = {}
    if kind == "straight":
        p = np.stack([L * s, 0 * s, 0 * s], 1)
        plane_normal = np.array([0, 0, 1.0])
    elif kind == "arch":
        ang = rng.uniform(0.3, 1.9 * math.pi)
        R = L / ang
        p = np.stack([R * np.sin(ang * s), R * (1 - np.cos(ang * s)), 0 * s], 1)
        info["angle"] = round(ang, 3)
        plane_normal = np.array([0, 0, 1.0])
    else:
        turns = rng.uniform(0.3, 4)
        R = logu(rng, 0.03, 0.4) * L
        circ = 2 * math.pi * R * turns
        pitch_len = math.sqrt(max(L ** 2 - circ ** 2, (0.05 * L) ** 2))
        if circ > L:  # keep total length ~L: reduce turns
            turns = 0.95 * L / (2 * math.pi * R)
            pitch_len = math.sqrt(L ** 2 - (2 * math.pi * R * turns) ** 2)
        t = 2 * math.pi * turns * s
        p = np.stack([R * np.cos(t), R * np.sin(t), pitch_len * s], 1)
        info["turns"] = round(turns, 2)
        info["helix_R/L"] = round(R / L, 3)
        plane_normal = None
    if rng.random() < 0.5:
        Rm = rot(rand_dir(rng), rng.uniform(0, math.pi))
        p = p @ Rm.T + rng.uniform(-0.2, 0.2, 3)
        if plane_normal is not None:
            plane_normal = Rm @ plane_normal
    rods = [list(range(n + 1))]
    sides = {"start": [0], "end": [n], "start2": [0, 1], "end2": [n - 1, n]}
    info.update({"rod": str(kind), "edges": n})
    return Geo(p, rods, sides, L, info, None, plane_normal)


def make_star(rng):
    narms = int(rng.choice([2, 3]))
    L = logu(rng, 0.02, 0.5)
    verts = [np.zeros(3)]
    rods = []
    ends = []
    planar = rng.random() < 0.4
    dirs = []
    for a in range(narms):
        if planar:
            th = 2 * math.pi * a / narms + rng.uniform(-0.5, 0.5)
            d = np.array([math.cos(th), math.sin(th), 0.0])
        else:
            d = rand_dir(rng)
            while any(abs(d @ e) > 0.95 for e in dirs):
                d = rand_dir(rng)
        dirs.append(d)
        la = L * rng.uniform(0.4, 1.0)
        n = int(rng.integers(2, 21))
        curved = rng.random() < 0.4
        perp = unit(np.cross(d, [0, 0, 1.0] if planar else rand_dir(rng)))
        if planar:
            perp = unit(np.cross([0, 0, 1.0], d))
        bend = rng.uniform(-0.6, 0.6) if curved else 0.0
        idx = [0]
        for k in range(1, n + 1):
            s = k / n
            verts.append(d * la * s + perp * bend * la * s * s)
            idx.append(len(verts) - 1)
        rods.append(idx)
        ends.append(idx[-1])
    v = np.array(verts)
    if rng.random() < 0.5:
        Rm = rot(rand_dir(rng), rng.uniform(0, math.pi))
        v = v @ Rm.T + rng.uniform(-0.2, 0.2, 3)
        pn = Rm @ np.array([0, 0, 1.0]) if planar else None
    else:
        pn = np.array([0, 0, 1.0]) if planar else None
    sides = {"centre": [0]}
    for a, e in enumerate(ends):
        sides["arm%d" % a] = [e]
    info = {"star": narms, "planar": bool(planar)}
    return Geo(v, rods, sides, L, info, None, pn)


# ----------------------------------------------------------------- scene
def material(rng):
    return {"young_modulus": float("%.4g" % logu(rng, 1e5, 5e9)), "poisson_ratio": float("%.3f" % rng.uniform(0, 0.49)),
            "density": float("%.4g" % logu(rng, 100, 8000))}


def radii_for(rng, geo, info):
    r = logu(rng, 0.2e-3, 5e-3)
    rt, rn = r, r
    if rng.random() < 0.3:
        ratio = rng.uniform(1.2, 5)
        if rng.random() < 0.5:
            rt, rn = r, r / ratio
        else:
            rt, rn = r / ratio, r
        rt, rn = max(rt, 0.2e-3), max(rn, 0.2e-3)
        info["elliptic"] = "%.2f" % (rt / rn)
    res = {"radius": [float("%.4g" % rt), float("%.4g" % rn)]}
    if rng.random() < 0.25:
        # per-vertex radii varying smoothly over space (along rods)
        d = rand_dir(rng)
        x = geo.v @ d
        x = (x - x.min()) / max(x.max() - x.min(), 1e-12)
        f0, f1 = logu(rng, 0.3, 3), logu(rng, 0.3, 3)
        wav = rng.uniform(0, 0.4)
        fac = f0 * (f1 / f0) ** x * (1 + wav * np.sin(7 * x))
        rr = np.clip(np.stack([rt * fac, rn * fac], 1), 0.2e-3, 5e-3)
        res["radii"] = [[float("%.4g" % a), float("%.4g" % b)] for a, b in rr]
        if rng.random() < 0.5:
            del res["radius"]
        info["radii"] = "per-vertex x%.2f..%.2f" % (fac.min(), fac.max())
    return res, rt, rn


def scene_for(rng, rodmesh, tmpdir, name):
    info = {}
    r = rng.random()
    if r < 0.6:
        geo, grid = make_sheet(rng, rodmesh, tmpdir, name)
        kind = "sheet_" + grid
    elif r < 0.8:
        geo = make_rod(rng)
        kind = "rod"
    else:
        geo = make_star(rng)
        kind = "star"
    info.update(geo.info)
    mat = material(rng)
    rad, rt, rn = radii_for(rng, geo, info)
    V = len(geo.v)
    L = geo.size
    E, nu = mat["young_modulus"], mat["poisson_ratio"]
    G = E / (2 * (1 + nu))
    EI = E * math.pi * min(rt, rn) ** 3 * max(rt, rn) / 4
    GJ = G * math.pi * rt * rn * (rt * rt + rn * rn) / 4
    F0 = EI / L ** 2
    M0 = GJ / L
    info["F0"] = "%.3g" % F0
    info["k0"] = "%.3g" % (EI / L ** 3)
    scene = {"format": "rodmesh-scene/1", "material": mat, "vertices": [rnd(p) for p in geo.v],
             "rods": [{"vertices": r} for r in geo.rods]}
    scene.update(rad)
    if geo.normals is not None:
        scene["normals"] = [rnd(n) for n in geo.normals]
    # gravity (scene-wide)
    grav = None
    if rng.random() < 0.4:
        if rng.random() < 0.5:
            grav = np.array([0, 0, -9.81])
        else:
            grav = rand_dir(rng) * logu(rng, 1.0, 50.0)
        scene["gravity"] = rnd(grav, 6)
        grav = np.array(scene["gravity"])
        info["gravity"] = "%s" % scene["gravity"]

    # supports: anchor (scene-wide), under-constrained variants
    under = None
    u = rng.random()
    sides = geo.sides
    if kind.startswith("sheet"):
        side_names = ["left", "right", "bottom", "top"]
        opposite = {"left": "right", "right": "left", "bottom": "top", "top": "bottom"}
    elif kind == "rod":
        side_names = ["start", "start2"]
        opposite = {"start": "end", "start2": "end2"}
    else:
        side_names = ["centre"] + ["arm%d" % a for a in range(info["star"])]
        opposite = None
    anchor, anchor_kind, anchor_vs = None, None, []
    if u < 0.12:
        under = str(rng.choice(["nothing held", "one pinned vertex", "collinear pins" if kind != "star" else "one pinned vertex"]))
        if under == "nothing held":
            if grav is None or rng.random() < 0.3:
                grav = rand_dir(rng) * 9.81
                scene["gravity"] = rnd(grav, 6)
                grav = np.array(scene["gravity"])
                info["gravity"] = "%s" % scene["gravity"]
        elif under == "one pinned vertex":
            anchor_vs = [int(rng.integers(0, V))]
            anchor_kind = "fixed"
        else:
            if kind == "rod":
                anchor_vs = [0, len(geo.v) - 1]
            else:
                anchor_vs = sides[str(rng.choice(side_names))][:]
            anchor_kind = "fixed"
        info["under"] = under
    else:
        anchor = str(rng.choice(side_names))
        anchor_vs = sides[anchor][:]
        anchor_kind = str(rng.choice(["clamped", "fixed"]))
        if len(anchor_vs) == 1 and anchor_kind == "fixed":
            anchor_kind = "clamped"  # a single pinned vertex is a mechanism: keep that for the 'under' group
        info["anchor"] = "%s %s (%d)" % (anchor_kind, anchor, len(anchor_vs))
    held = set(anchor_vs)
    free = [i for i in range(V) if i not in held]
    free_ends = [i for i in geo.free_ends() if i not in held]

    nposes = int(rng.choice([1, 1, 2, 2, 3]))
    poses = []
    pose_info = []
    for pi in range(nposes):
        pose = {"name": "p%d" % pi, "weight": 1.0}
        desc = []
        if anchor_vs:
            pose[anchor_kind] = [{"vertex": int(i)} for i in anchor_vs]
        pose_held = set(anchor_vs)
        opts = ["forces", "forces", "prescribed", "moments", "mixed", "gravity"]
        lt = str(rng.choice(opts))
        if lt == "gravity" and grav is None:
            lt = "forces"
        if lt == "prescribed" and (under is not None or opposite is None or opposite.get(anchor) is None):
            lt = "forces"
        if lt == "moments" and not free_ends:
            lt = "forces"
        if under == "nothing held" and lt != "gravity":
            lt = "forces" if rng.random() < 0.5 else "gravity"
        if lt == "prescribed" or (lt == "mixed" and opposite is not None and anchor is not None and opposite.get(anchor)
                                   and rng.random() < 0.5):
            mv = [i for i in sides[opposite[anchor]] if i not in pose_held]
            if mv:
                P = geo.v[mv]
                c = P.mean(0)
                frac = rng.uniform(0, 0.4)
                tr = rand_dir(rng) * frac * L if rng.random() < 0.8 else np.zeros(3)
                ang = math.radians(rng.uniform(0, 90)) if rng.random() < 0.6 else 0.0
                ax = rand_dir(rng)
                Rm = rot(ax, ang)
                newp = (P - c) @ Rm.T + c + tr
                pose["fixed"] = pose.get("fixed", []) + [{"vertex": int(i), "position": rnd(p)} for i, p in zip(mv, newp)]
                pose_held |= set(mv)
                desc.append("prescribed %s: move %.2fL rot %.0fdeg" % (opposite[anchor], frac if np.any(tr) else 0,
                                                                          math.degrees(ang)))
        if lt in ("forces", "mixed"):
            cand = [i for i in range(V) if i not in pose_held]
            nf = int(min(len(cand), rng.integers(1, 5)))
            fl = []
            mag = F0 * 10 ** rng.uniform(-4, 3)
            for i in rng.choice(cand, nf, replace=False):
                if geo.plane_normal is not None and rng.random() < 0.5:
                    d = rand_dir(rng)
                    d = unit(d - (d @ geo.plane_normal) * geo.plane_normal)
                    dtag = "in-plane"
                elif geo.plane_normal is not None and rng.random() < 0.5:
                    d = geo.plane_normal * rng.choice([-1, 1])
                    dtag = "normal"
                else:
                    d = rand_dir(rng)
                    dtag = "3d"
                f = np.clip(d * mag, -1e9, 1e9)
                fl.append({"vertex": int(i), "force": rnd(f, 8)})
            pose["forces"] = fl
            desc.append("%d forces %s %.3g N (%.1e F0)" % (nf, dtag, mag, mag / F0))
        if lt in ("moments", "mixed") and free_ends:
            cand = [i for i in free_ends if i not in pose_held]
            if cand:
                nm = int(min(len(cand), rng.integers(1, 3)))
                m = M0 * 10 ** rng.uniform(-3, 1) * rng.choice([-1, 1])
                pose["twisting_moments"] = [{"vertex": int(i), "moment": float("%.6g" % m)}
                                            for i in rng.choice(cand, nm, replace=False)]
                desc.append("%d moments %.3g Nm (%.1e GJ/L)" % (nm, m, abs(m) / M0))
        if lt == "gravity":
            desc.append("gravity only")
        if grav is not None and lt != "gravity":
            desc.append("+gravity")
        poses.append(pose)
        pose_info.append("; ".join(desc))
    scene["poses"] = poses
    info["poses"] = pose_info
    info["V"] = V
    info["E"] = E
    info["r"] = "%.3g/%.3g mm" % (rt * 1e3, rn * 1e3)
    info["size"] = "%.3g m" % L
    el = geo.edge_lengths()
    info["r/edge"] = "%.2g" % (max(rt, rn) / el.min())
    return scene, kind, info, under


# ----------------------------------------------------------------- judging
def vertex_masses(scene):
    v = np.array(scene["vertices"], float)
    V = len(v)
    if "radii" in scene:
        rr = np.array(scene["radii"], float)
    else:
        rr = np.tile(np.array(scene["radius"], float), (V, 1))
    area = math.pi * rr[:, 0] * rr[:, 1]
    m = np.zeros(V)
    rho = scene["material"]["density"]
    for r in scene["rods"]:
        idx = r["vertices"]
        for a, b in zip(idx[:-1], idx[1:]):
            le = np.linalg.norm(v[b] - v[a])
            me = rho * le * 0.5 * (area[a] + area[b])
            m[a] += me / 2
            m[b] += me / 2
    return m


def judge(scene_path, h5path, k0):
    res = {"status": "", "pose_status": "", "stable": "", "min_eig": "", "crit": 0, "max_disp_L": "", "nan": "",
           "held_err": "", "work": "", "problems": [], "message": "", "effects_note": "", "effects": "", "mech": False,
           "notes": []}
    with open(scene_path) as f:
        scene = json.load(f)
    rest = np.array(scene["vertices"], float)
    ext = rest.max(0) - rest.min(0)
    L = float(np.linalg.norm(ext))
    grav = np.array(scene.get("gravity", [0, 0, 0]), float)
    m = vertex_masses(scene)
    try:
        f = h5py.File(h5path, "r")
    except Exception as e:  # noqa
        res["problems"].append("archive unreadable: %s" % e)
        return res
    with f:
        res["status"] = str(f.attrs.get("status", ""))
        res["message"] = str(f.attrs.get("message", ""))
        res["effects_note"] = str(f.attrs.get("effects_note", ""))
        res["effects"] = str(f["model"].attrs.get("effects", "")) + (" planar" if f["model"].attrs.get("planar", 0) else "")
        pst, stab, eig, disps, nans, herr, works = [], [], [], [], [], [], []
        for p in scene["poses"]:
            name = p["name"]
            if name not in f["poses"]:
                res["problems"].append("pose %s missing" % name)
                continue
            g = f["poses"][name]
            x = g["positions"][()]
            a = dict(g.attrs)
            st = str(a.get("status", ""))
            pst.append(st)
            stab.append(str(a.get("stable", "-")))
            e = a.get("smallest_eigenvalue", float("nan"))
            ue = a.get("unloaded_smallest_eigenvalue", float("nan"))
            eig.append("%.2g/%.2g" % (e, ue))
            if np.isfinite(ue) and ue < 1e-8 * k0:
                res["mech"] = True
            if "critical_points" in g:
                res["crit"] += g["critical_points"].shape[0]
            fin = bool(np.all(np.isfinite(x)))
            nans.append(not fin)
            if not fin:
                res["problems"].append("%s: non-finite positions" % name)
                continue
            if "twist" in g and not np.all(np.isfinite(g["twist"][()])):
                res["problems"].append("%s: non-finite twist" % name)
            u = x - rest
            dmax = float(np.max(np.linalg.norm(u, axis=1)))
            disps.append(dmax / L)
            he = 0.0
            for c in p.get("clamped", []):
                he = max(he, float(np.linalg.norm(u[c["vertex"]])))
            for c in p.get("fixed", []):
                tgt = np.array(c["position"]) if "position" in c else rest[c["vertex"]]
                he = max(he, float(np.linalg.norm(x[c["vertex"]] - tgt)))
            herr.append(he)
            if he > 1e-9 and st == "converged":
                res["problems"].append("%s: held vertex off by %.3g m" % (name, he))
            elif he > 1e-9:
                res["notes"].append("%s (%s): held vertex %.3g m from its full-load position" % (name, st, he))
            prescribed = any("position" in c for c in p.get("fixed", []))
            moments = bool(p.get("twisting_moments"))
            if not prescribed and not moments and st == "converged":
                F = np.zeros_like(rest)
                for fo in p.get("forces", []):
                    F[fo["vertex"]] += np.array(fo["force"], float)
                F += m[:, None] * grav[None, :]
                W = float(np.sum(F * u))
                scale = float(np.sum(np.linalg.norm(F, axis=1) * np.linalg.norm(u, axis=1)))
                if scale > 0:
                    works.append(W / scale)
                    if W < -1e-6 * scale:
                        res["problems"].append("%s: negative work of the loads (W/|F||u| = %.3g)" % (name, W / scale))
            if st == "converged" and a.get("stable", 1) == 0:
                res["problems"].append("%s: converged but stable=0" % name)
            if st == "converged" and np.isfinite(e) and e < -1e-8 * k0:
                res["problems"].append("%s: converged with negative smallest eigenvalue %.3g" % (name, e))
            if dmax > 100 * max(L, 1e-3) and st == "converged":
                res["problems"].append("%s: converged with displacement %.3g x diag" % (name, dmax / L))
        res["pose_status"] = ",".join(pst)
        res["stable"] = ",".join(stab)
        res["min_eig"] = " ".join(eig)
        res["max_disp_L"] = "%.3g" % max(disps) if disps else ""
        res["nan"] = any(nans)
        res["held_err"] = "%.2g" % max(herr) if herr else ""
        res["work"] = "%.3g" % min(works) if works else ""
        if res["status"] == "converged" and any(s != "converged" for s in pst):
            res["problems"].append("root status converged but a pose is %s" % pst)
    return res


def run_one(rodmesh, scene_path, out_h5):
    if os.path.exists(out_h5):
        os.remove(out_h5)
    t0 = time.time()
    try:
        r = subprocess.run([rodmesh, "simulate", scene_path, "-o", out_h5], capture_output=True, text=True,
                           timeout=TIMEOUT)
        rc, so, se = r.returncode, r.stdout, r.stderr
    except subprocess.TimeoutExpired as e:
        rc = "timeout"
        so = (e.stdout or b"").decode("utf8", "replace") if isinstance(e.stdout, bytes) else (e.stdout or "")
        se = (e.stderr or b"").decode("utf8", "replace") if isinstance(e.stderr, bytes) else (e.stderr or "")
    return rc, time.time() - t0, so, se


def outcome(rc, under):
    if rc == "timeout":
        o = "timeout"
    elif rc == 0:
        o = "exit0"
    elif rc == 1:
        o = "exit1"
    elif rc == 2:
        o = "exit2"
    else:
        o = "crash(%s)" % rc
    return ("under:" if under else "") + o


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=150)
    ap.add_argument("--first", type=int, default=0, help="run only cases with index >= FIRST (generation is full)")
    ap.add_argument("--rodmesh", default=RODMESH)
    ap.add_argument("--cases", default="/tmp/rodmesh_sweep3/cases")
    ap.add_argument("--out", default="/tmp/rodmesh_sweep3/out")
    ap.add_argument("--only", default="", help="comma-separated case names to run")
    ap.add_argument("--no-rerun", action="store_true")
    ap.add_argument("--generate-only", action="store_true")
    a = ap.parse_args()
    os.makedirs(a.cases, exist_ok=True)
    os.makedirs(a.out, exist_ok=True)
    master = np.random.default_rng(a.seed)
    seeds = master.integers(0, 2 ** 31, a.count)
    cases = []
    for i in range(a.count):
        name = "s%d_%03d" % (a.seed, i)
        rng = np.random.default_rng(int(seeds[i]))
        scene, kind, info, under = scene_for(rng, a.rodmesh, a.cases, name)
        path = os.path.join(a.cases, name + ".json")
        with open(path, "w") as f:
            json.dump(scene, f, indent=None)
        cases.append({"name": name, "kind": kind, "info": info, "under": under, "scene": path})
    with open(os.path.join(a.cases, "index_seed%d.json" % a.seed), "w") as f:
        json.dump(cases, f, indent=1)
    print("generated %d scenes in %s" % (len(cases), a.cases), flush=True)
    if a.generate_only:
        return
    only = set(a.only.split(",")) if a.only else None
    results = []
    for i, c in enumerate(cases):
        if i < a.first or (only and c["name"] not in only):
            continue
        h5 = os.path.join(a.out, c["name"] + ".h5")
        rc, dt, so, se = run_one(a.rodmesh, c["scene"], h5)
        with open(os.path.join(a.out, c["name"] + ".log"), "w") as f:
            f.write("exit %s  %.2f s\n--- stdout\n%s\n--- stderr\n%s" % (rc, dt, so, se))
        row = {"name": c["name"], "kind": c["kind"], "under": c["under"] or "", "rc": rc, "time": round(dt, 3),
               "outcome": outcome(rc, c["under"])}
        if "mode without stiffness" in se and not c["under"]:
            row["outcome"] = "mech:" + row["outcome"]
        j = judge(c["scene"], h5, float(c["info"]["k0"])) if os.path.exists(h5) else {"problems": [], "mech": False}
        if rc in (0, 1) and not os.path.exists(h5):
            j["problems"].append("no archive written")
        if rc == 2:
            j["problems"].append("exit 2 on a generated scene")
        if dt > SLOW:
            j["problems"].append("slow: %.1f s" % dt)
        row.update(j)
        if j.get("mech") and not c["under"] and not row["outcome"].startswith("mech:"):
            row["outcome"] = "mech:" + row["outcome"]
        tail = [l for l in se.strip().splitlines() if l.strip()][-4:]
        row["stderr_tail"] = " | ".join(tail)
        row["warnings"] = " | ".join(l for l in se.splitlines() if "warning" in l.lower())[:300]
        row["info"] = json.dumps(c["info"])
        row["rerun"] = ""
        results.append(row)
        print("%-10s %-10s %-16s %6.2fs %-14s %s %s" % (c["name"], c["kind"], row["outcome"], dt, row.get("status", ""),
                                                      row.get("pose_status", ""),
                                                      ("PROBLEMS: " + "; ".join(row["problems"])) if row["problems"] else ""),
              flush=True)
    # confirm every exit-1 / crash / timeout once more
    if not a.no_rerun:
        for row in results:
            if row["rc"] == 0 or row["rc"] == 2:
                continue
            c = next(c for c in cases if c["name"] == row["name"])
            h5 = os.path.join(a.out, c["name"] + "_rerun.h5")
            rc, dt, so, se = run_one(a.rodmesh, c["scene"], h5)
            same = (rc == row["rc"])
            row["rerun"] = "exit %s %.1fs%s" % (rc, dt, "" if same else " DIFFERENT")
            print("rerun %s: %s" % (row["name"], row["rerun"]), flush=True)
    write_reports(a, results)


def write_reports(a, results):
    tag = "seed%d" % a.seed
    keys = ["name", "kind", "under", "outcome", "rc", "time", "status", "pose_status", "stable", "min_eig", "crit",
            "max_disp_L", "nan", "held_err", "work", "mech", "effects", "effects_note", "problems", "notes", "message", "stderr_tail",
            "warnings", "rerun", "info"]
    with open(os.path.join(a.out, "results_%s.csv" % tag), "w", newline="") as f:
        w = csv.DictWriter(f, keys, extrasaction="ignore")
        w.writeheader()
        for r in results:
            rr = dict(r)
            rr["problems"] = "; ".join(r.get("problems", []))
            rr["notes"] = "; ".join(r.get("notes", []))
            w.writerow(rr)
    with open(os.path.join(a.out, "results_%s.json" % tag), "w") as f:
        json.dump(results, f, indent=1, default=str)
    counts = {}
    for r in results:
        counts[r["outcome"]] = counts.get(r["outcome"], 0) + 1
    lines = ["# sweep 3, %s: %d runs" % (tag, len(results)), "", "| outcome | runs |", "|---|---|"]
    lines += ["| %s | %d |" % (k, v) for k, v in sorted(counts.items())]
    lines += ["", "## Problem cases", "", "| case | kind | what | exit | s | status | problems | stderr tail | rerun |",
              "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        bad = r["rc"] != 0 or r.get("problems")
        if bad:
            lines.append("| %s | %s%s | %s | %s | %.1f | %s [%s] | %s | %s | %s |" % (
                r["name"], r["kind"], (" (" + r["under"] + ")") if r["under"] else "", r["info"].replace("|", "/"),
                r["rc"], r["time"], r.get("status", ""), r.get("pose_status", ""),
                "; ".join(r.get("problems", []) + r.get("notes", [])) + ((" MESSAGE: " + r.get("message", "")[:300]) if r.get("message") else ""),
                r["stderr_tail"].replace("|", "/")[-400:], r["rerun"]))
    lines += ["", "## Slowest", ""]
    for r in sorted(results, key=lambda r: -r["time"])[:10]:
        lines.append("- %s %.2f s (%s, %s)" % (r["name"], r["time"], r["kind"], r["outcome"]))
    with open(os.path.join(a.out, "summary_%s.md" % tag), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines[:12]))


if __name__ == "__main__":
    main()
