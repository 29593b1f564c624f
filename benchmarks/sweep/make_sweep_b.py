#!/usr/bin/python3
"""Second acceptance sweep for rodmesh (families not in benchmarks/sweep).

    /usr/bin/python3 benchmarks/sweep/make_sweep_b.py --rodmesh build/apps/rodmesh --out /work/sweep2/cases [--only a,b]

Writes OUT/CASE.json, OUT/CASE.hidden.json (reachable cases), OUT/cases.json
(the index run_sweep.py / run2.py reads).
"""
import argparse
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_sweep as ms  # noqa: E402
from make_sweep import grid, held_ids, rot, fixed_list, smooth_r, smooth_d, finish_geometric  # noqa: E402

BIN = "rodmesh"


def reach(scene, poses, params, bounds, n, tmp, tag, rfun=None, dfun=None, radius=(0.002, 0.002), grav=None):
    return ms.finish_reachable(scene, poses, params, bounds, n, tmp, tag, rfun=rfun, dfun=dfun, radius=radius,
                               grav=grav)


def sides(V, tol=1e-6):
    x0, x1, y0, y1 = V[:, 0].min(), V[:, 0].max(), V[:, 1].min(), V[:, 1].max()
    return (held_ids(V, V[:, 0] < x0 + tol), held_ids(V, V[:, 0] > x1 - tol),
            held_ids(V, V[:, 1] < y0 + tol), held_ids(V, V[:, 1] > y1 - tol))


def connections(s):
    cnt = {}
    for r in s["rods"]:
        for v in (r["vertices"][0], r["vertices"][-1]):
            cnt[v] = cnt.get(v, 0) + 1
    return sorted(v for v, c in cnt.items() if c >= 2), sorted(v for v, c in cnt.items() if c == 1)


def nearest(V, ids, p):
    ids = np.asarray(ids)
    return int(ids[np.argmin(np.linalg.norm(V[ids] - np.asarray(p), axis=1))])


# ------------------------------------------------------------ mass-spring model
def mass_spring(scene, poses, radius=0.002, bend_factor=0.5, iters=60):
    """Equilibria of a different physical model: axial springs on rod edges,
    a linear (Laplacian) bending energy along each rod, lumped masses; held
    vertices at their prescribed positions; gravity and point forces."""
    V = np.asarray(scene["vertices"], float)
    n = len(V)
    E = scene["material"]["young_modulus"]
    rho = scene["material"]["density"]
    g = np.asarray(scene.get("gravity", [0, 0, 0]), float)
    A = math.pi * radius ** 2
    I = math.pi * radius ** 4 / 4
    springs, lap = [], []
    mass = np.zeros(n)
    for r in scene["rods"]:
        ids = r["vertices"]
        for a, b in zip(ids[:-1], ids[1:]):
            L = float(np.linalg.norm(V[a] - V[b]))
            springs.append((a, b, L, E * A / L))
            mass[a] += rho * A * L / 2
            mass[b] += rho * A * L / 2
        for a, b, c in zip(ids[:-2], ids[1:-1], ids[2:]):
            h = 0.5 * (np.linalg.norm(V[a] - V[b]) + np.linalg.norm(V[c] - V[b]))
            lap.append((a, b, c, bend_factor * E * I / h ** 3))
    out = {}
    for p in poses:
        X = V.copy()
        held = {}
        for f in p.get("fixed", []):
            held[f["vertex"]] = np.asarray(f.get("position", V[f["vertex"]]), float)
        for c in p.get("clamped", []):
            held[c["vertex"]] = V[c["vertex"]]
        F = mass[:, None] * g[None, :]
        for f in p.get("forces", []):
            F[f["vertex"]] += f["force"]
        free = np.array([i for i in range(n) if i not in held])
        fd = (free[:, None] * 3 + np.arange(3)[None, :]).ravel()
        for lam in np.linspace(0.1, 1.0, 10):
            for i, q in held.items():
                X[i] = V[i] + lam * (q - V[i])
            for it in range(iters):
                G = -lam * F.ravel().copy()
                H = np.zeros((3 * n, 3 * n))
                for a, b, L, k in springs:
                    d = X[b] - X[a]
                    r = np.linalg.norm(d)
                    u = d / r
                    f = k * (r - L) * u
                    G[3 * a:3 * a + 3] -= f
                    G[3 * b:3 * b + 3] += f
                    Kb = k * (np.outer(u, u) + max(r - L, 0.0) / r * (np.eye(3) - np.outer(u, u)))
                    for i, j, sg in ((a, a, 1), (b, b, 1), (a, b, -1), (b, a, -1)):
                        H[3 * i:3 * i + 3, 3 * j:3 * j + 3] += sg * Kb
                for a, b, c, k in lap:
                    w = (X[a] - 2 * X[b] + X[c]) - (V[a] - 2 * V[b] + V[c])
                    cf = (1.0, -2.0, 1.0)
                    for i, ci in zip((a, b, c), cf):
                        G[3 * i:3 * i + 3] += k * ci * w
                        for j, cj in zip((a, b, c), cf):
                            H[3 * i:3 * i + 3, 3 * j:3 * j + 3] += k * ci * cj * np.eye(3)
                g_f = G[fd]
                if np.linalg.norm(g_f) < 1e-10 * max(1.0, np.abs(F).sum()):
                    break
                dx = np.linalg.solve(H[np.ix_(fd, fd)] + 1e-12 * np.eye(len(fd)), -g_f)
                step = np.linalg.norm(dx.reshape(-1, 3), axis=1).max()
                if step > 0.01:
                    dx *= 0.01 / step
                X.reshape(-1)[fd] += dx
        out[p["name"]] = X.copy()
    return out


# ------------------------------------------------------------ cases
def c_hex452_corners(tmp):
    """large hex sheet 6x6 cells K=5 (452 v), held (fixed) at the 4 corner
    connections only; gravity; pose 2 adds 0.3 N down at the centre; radii
    only; reachable."""
    s = grid("hex", (0.3, 0.3), (6, 6), 5, tmp)
    V = np.array(s["vertices"])
    con, _ = connections(s)
    mn, mx = V.min(0), V.max(0)
    C = sorted({nearest(V, con, [x, y, 0]) for x in (mn[0], mx[0]) for y in (mn[1], mx[1])})
    ctr = nearest(V, range(len(V)), [0, 0, 0])
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(C)),
             dict(name="poke", weight=1.0, fixed=fixed_list(C), forces=[dict(vertex=ctr, force=[0, 0, -0.3])])]
    return reach(s, poses, ["radii"], (0.001, 0.006), 4, tmp, "hex452", rfun=smooth_r(0.002, 0.005, V),
                 radius=(0.003, 0.003), grav=[0, 0, -9.81])


def c_quad_single_clamp(tmp):
    """quad sheet 4x4 K=4, clamped at ONE connection (middle of the left
    side), nothing prescribed: gravity only; pose 2 gravity + 0.05 N sideways
    (+y) at the far corner; radii and rest shape (3D); reachable."""
    s = grid("quad", (0.12, 0.12), (4, 4), 4, tmp)
    V = np.array(s["vertices"])
    con, _ = connections(s)
    c = nearest(V, con, [V[:, 0].min(), 0, 0])
    far = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="grav", weight=1.0, clamped=[dict(vertex=c)]),
             dict(name="grav_side", weight=1.0, clamped=[dict(vertex=c)],
                  forces=[dict(vertex=far, force=[0, 0.05, 0])])]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "clamp1",
                 rfun=smooth_r(0.0015, 0.0045, V), dfun=smooth_d(0.003, V), grav=[0, 0, -9.81])


def _ms_scene(tmp):
    s = grid("tri", (0.12, 0.1), (4, 3), 4, tmp)
    s["radius"] = [0.002, 0.002]
    s["gravity"] = [0, 0, -9.81]
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(L)),
             dict(name="pull", weight=1.0, fixed=fixed_list(L),
                  forces=[dict(vertex=i, force=[0.3 / len(R), 0, 0.06 / len(R)]) for i in R])]
    T = mass_spring(s, poses)
    return s, poses, T


def c_ms_radii(tmp):
    """tri sheet 4x3 K=4, left held, gravity; poses sag / pull (0.3 N +x,
    0.06 N up on the right side); targets from a numpy mass-spring model
    (axial springs + Laplacian bending); radii only; unreachable."""
    s, poses, T = _ms_scene(tmp)
    return finish_geometric(s, poses, T, ["radii"], (0.0005, 0.008), 4, grav=[0, 0, -9.81])


def c_ms_rest(tmp):
    """as ms_radii, rest shape only."""
    s, poses, T = _ms_scene(tmp)
    return finish_geometric(s, poses, T, ["rest_shape"], (0.0005, 0.008), 4, grav=[0, 0, -9.81])


def c_ms_both(tmp):
    """as ms_radii, radii and rest shape."""
    s, poses, T = _ms_scene(tmp)
    return finish_geometric(s, poses, T, ["radii", "rest_shape"], (0.0005, 0.008), 4, grav=[0, 0, -9.81])


def comb_scene(teeth=4, K=21):
    Vs, rods = [], []

    def add(p):
        Vs.append([float(x) for x in p])
        return len(Vs) - 1

    def line(a, b, k):
        ids = [a]
        for t in range(1, k - 1):
            f = t / (k - 1)
            ids.append(add((1 - f) * np.array(Vs[a]) + f * np.array(Vs[b])))
        return ids + [b]
    root = add([0, 0, 0])
    prev = root
    tips, joints = [], []
    for t in range(teeth):
        j = add([0.03 * (t + 1), 0, 0])
        rods.append(dict(vertices=line(prev, j, 4)))
        tip = add([0.03 * (t + 1), 0.1, 0])
        rods.append(dict(vertices=line(j, tip, K)))
        tips.append(tip); joints.append(j)
        prev = j
    # last joint must be a connection: add a short tail
    tail = add([0.03 * teeth + 0.03, 0, 0])
    rods.append(dict(vertices=line(prev, tail, 4)))
    s = dict(format="rodmesh-scene/1", material=dict(young_modulus=3.2e7, poisson_ratio=0.48, density=1200.0),
             vertices=Vs, rods=rods)
    return s, root, tips, tail


def c_comb_moments(tmp):
    """planar comb (backbone along x, 4 teeth of 21 vertices, 20 edges, free
    ends; no normals), root clamped; pose 'twist' 5e-3 N m twisting moments
    at the tooth tips (~100 deg of twist); pose 'bend' 0.05 N down at the
    tips (large rotation); radii and rest shape (3D hidden rest
    displacement), control_points_per_rod 6; reachable."""
    s, root, tips, tail = comb_scene()
    V = np.array(s["vertices"])
    poses = [dict(name="twist", weight=1.0, clamped=[dict(vertex=root)],
                  twisting_moments=[dict(vertex=t, moment=5e-3) for t in tips]),
             dict(name="bend", weight=1.0, clamped=[dict(vertex=root)],
                  forces=[dict(vertex=t, force=[0, 0, -0.05]) for t in tips])]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 6, tmp, "comb",
                 rfun=smooth_r(0.0015, 0.004, V), dfun=smooth_d(0.003, V))


def _strip_handle(tmp):
    s = grid("quad", (0.3, 0.03), (10, 1), 4, tmp)
    V = np.array(s["vertices"])
    x0, x1 = V[:, 0].min(), V[:, 0].max()
    L = held_ids(V, V[:, 0] < x0 + 1e-6)
    R = held_ids(V, V[:, 0] > x1 - 0.015)
    return s, V, x0, x1, L, R


def roll(V, R, x0, x1, phi):
    Ls = x1 - x0
    rho = Ls / phi
    return rot(V[R] - [x1, 0, 0], np.zeros(3), [0, -1, 0], phi) + [x0 + rho * math.sin(phi), 0, rho * (1 - math.cos(phi))]


def c_strip_roll180(tmp):
    """quad strip 10x1 K=4 (0.3 m x 0.03 m), left clamped; the right handle
    (last half cell, a rigid block) prescribed rolled up onto a circular arc
    by 120 deg and by 180 deg (rotation about y); radii and rest shape;
    reachable (hidden design simulated)."""
    s, V, x0, x1, L, R = _strip_handle(tmp)
    poses = [dict(name="roll120", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  fixed=fixed_list(R, roll(V, R, x0, x1, math.radians(120)))),
             dict(name="roll180", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  fixed=fixed_list(R, roll(V, R, x0, x1, math.radians(180))))]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "roll180",
                 rfun=smooth_r(0.0015, 0.004, V), dfun=smooth_d(0.002, V, comps=(0, 1)))


def c_strip_twist180(tmp):
    """same strip; right handle prescribed twisted about the strip axis by
    90 deg and 180 deg (the linear load path of the 180 deg twist collapses
    the handle's width at half load); radii and rest shape; targets:
    linear helicoid (geometric), unreachable."""
    s, V, x0, x1, L, R = _strip_handle(tmp)
    u = (V[:, 0] - x0) / (x1 - x0)
    poses, T = [], {}
    for deg in (90, 180):
        a = math.radians(deg)
        nm = "twist%d" % deg
        poses.append(dict(name=nm, weight=1.0, clamped=[dict(vertex=i) for i in L],
                          fixed=fixed_list(R, rot(V[R], np.zeros(3), [1, 0, 0], a))))
        Tt = np.array([rot(V[i:i + 1], np.zeros(3), [1, 0, 0], a * u[i])[0] for i in range(len(V))])
        Tt[R] = rot(V[R], np.zeros(3), [1, 0, 0], a)
        T[nm] = Tt
    return finish_geometric(s, poses, T, ["radii", "rest_shape"], (0.001, 0.005), 4)


def c_tri_stretch(tmp):
    """tri sheet 4x3 K=3, left and right sides held; right side prescribed
    +8% and +20% of the width in x (pulling apart, stretch dominated);
    radii and rest shape (in plane); reachable."""
    s = grid("tri", (0.12, 0.08), (4, 3), 3, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    w = np.ptp(V[:, 0])
    poses = [dict(name="s8", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0.08 * w, 0, 0])),
             dict(name="s20", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0.20 * w, 0, 0]))]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "stretch",
                 rfun=smooth_r(0.0012, 0.0045, V), dfun=smooth_d(0.002, V, comps=(0, 1)))


def c_quad_six_poses(tmp):
    """quad sheet 3x3 K=4, left held, gravity; 6 poses: sag; right lifted
    15 mm; right pushed 5 mm in +x (weight 0); 0.1 N at a corner; an
    unloaded-by-forces pose with target identical to ... its own simulated
    state (same as sag but weight 0.5); right side rotated 45 deg about x
    (weight 0); radii and rest shape; reachable."""
    s = grid("quad", (0.1, 0.1), (3, 3), 4, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    c = V[R].mean(0)
    corner = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(L)),
             dict(name="lift", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0, 0.015])),
             dict(name="push0", weight=0.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0.005, 0, 0])),
             dict(name="corner", weight=2.0, fixed=fixed_list(L), forces=[dict(vertex=corner, force=[0, 0.03, 0.1])]),
             dict(name="sag_dup", weight=0.5, fixed=fixed_list(L)),
             dict(name="twist45_0", weight=0.0,
                  fixed=fixed_list(L) + fixed_list(R, rot(V[R], c, [1, 0, 0], math.radians(45))))]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "six",
                 rfun=smooth_r(0.0012, 0.0045, V), dfun=smooth_d(0.002, V), grav=[0, 0, -9.81])


def c_zero_start(tmp):
    """tri sheet 3x3 K=4, two corners held, no loads, no gravity; both poses'
    targets identical to the rest state (initial RMS exactly 0); radii and
    rest shape."""
    s = grid("tri", (0.09, 0.09), (3, 3), 4, tmp)
    V = np.array(s["vertices"])
    c1 = int(np.argmin(V[:, 0] + V[:, 1])); c2 = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="a", weight=1.0, fixed=fixed_list([c1, c2])),
             dict(name="b", weight=3.0, fixed=fixed_list([c1]))]
    return finish_geometric(s, poses, dict(a=V, b=V), ["radii", "rest_shape"], (0.001, 0.005), 4)


def c_grav_target_rest(tmp):
    """hex sheet 3x2 K=4 held at the left side, gravity + a pose with 0.05 N
    down at the right; targets = the REST state (only infinitely stiff rods
    reach it); radii only: the optimum sits at the upper bound."""
    s = grid("hex", (0.1, 0.08), (3, 2), 4, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(L)),
             dict(name="load", weight=1.0, fixed=fixed_list(L),
                  forces=[dict(vertex=i, force=[0, 0, -0.05 / len(R)]) for i in R])]
    return finish_geometric(s, poses, dict(sag=V, load=V), ["radii"], (0.001, 0.005), 4, grav=[0, 0, -9.81])


def c_rods2_tri(tmp):
    """tri sheet 5x5 with 2-vertex rods (1 edge per rod), bottom held,
    gravity; pose 2 top lifted 10 mm; radii and rest shape, default
    control_points_per_rod 4 (> vertices per rod); reachable."""
    s = grid("tri", (0.1, 0.1), (5, 5), 2, tmp)
    V = np.array(s["vertices"])
    _, _, B, T = sides(V)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(B)),
             dict(name="lift", weight=1.0, fixed=fixed_list(B) + fixed_list(T, V[T] + [0, 0, 0.01]))]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "rods2",
                 rfun=smooth_r(0.0012, 0.0045, V), dfun=smooth_d(0.002, V), grav=[0, 0, -9.81])


def c_rods2_quad_cp2(tmp):
    """quad sheet 4x4 with 2-vertex rods, control_points_per_rod 2; left
    side held; in-plane shear of the right side 8 mm (y) and a 0.05 N
    out-of-plane corner force; radii only; reachable."""
    s = grid("quad", (0.1, 0.1), (4, 4), 2, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    corner = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="shear", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0.008, 0])),
             dict(name="corner", weight=1.0, fixed=fixed_list(L), forces=[dict(vertex=corner, force=[0, 0, 0.05])])]
    return reach(s, poses, ["radii"], (0.001, 0.005), 2, tmp, "rods2q", rfun=smooth_r(0.0012, 0.0045, V))


def c_quad_k25_cp10(tmp):
    """quad sheet 2x2 cells with 25 vertices per rod (24 edges),
    control_points_per_rod 10; left held; gravity; right lifted 20 mm;
    radii and rest shape; reachable."""
    s = grid("quad", (0.2, 0.2), (2, 2), 25, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(L)),
             dict(name="lift", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0, 0.02]))]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 10, tmp, "k25",
                 rfun=smooth_r(0.0015, 0.0045, V), dfun=smooth_d(0.003, V), grav=[0, 0, -9.81])


def _planar(tmp, eps):
    s = grid("tri", (0.15, 0.1), (5, 3), 4, tmp)
    V = np.array(s["vertices"])
    if eps:
        rng = np.random.default_rng(7)
        V[:, 2] += eps * rng.standard_normal(len(V))
        s["vertices"] = V.tolist()
    L, R, B, T = sides(V, 1e-5)
    corner = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="shear", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0.015, 0])),
             dict(name="pull", weight=1.0, fixed=fixed_list(L), forces=[dict(vertex=corner, force=[0.2, -0.1, 0])])]
    return s, V, poses


def c_planar_inplane(tmp):
    """planar tri sheet 5x3 K=4, all loads in plane (prescribed shear of
    the right side 15 mm in y; 0.2 N in-plane corner force), targets in
    plane; radii and rest shape (in-plane hidden displacement); reachable;
    solved in plane."""
    s, V, poses = _planar(tmp, 0.0)
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "planar",
                 rfun=smooth_r(0.0012, 0.0045, V), dfun=smooth_d(0.003, V, comps=(0, 1)))


def c_nearly_planar(tmp):
    """planar_inplane with every z perturbed by 1e-6 m (nearly planar: a 3D
    scene); same loads; reachable from its own hidden design."""
    s, V, poses = _planar(tmp, 1e-6)
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "nplanar",
                 rfun=smooth_r(0.0012, 0.0045, V), dfun=smooth_d(0.003, V, comps=(0, 1)))


def _bounds_scene(tmp):
    s = grid("quad", (0.12, 0.09), (4, 3), 4, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="lift", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0, 0.02])),
             dict(name="sag", weight=1.0, fixed=fixed_list(L))]
    return s, V, poses


def c_tight_bounds(tmp):
    """quad sheet 4x3 K=4, left held, gravity; right lifted 20 mm / sag;
    radius bounds [1.9, 2.1] mm, initial 2.0; hidden radii in [1.92, 2.08]
    mm; radii only; reachable."""
    s, V, poses = _bounds_scene(tmp)
    return reach(s, poses, ["radii"], (0.0019, 0.0021), 4, tmp, "tight", rfun=smooth_r(0.00192, 0.00208, V),
                 radius=(0.002, 0.002), grav=[0, 0, -9.81])


def c_init_at_bound(tmp):
    """same sheet; bounds [1.9, 2.1] mm, initial radii AT the upper bound
    2.1 mm; targets from a hidden design with radii 1-4 mm (outside the
    bounds): unreachable; radii only."""
    s, V, poses = _bounds_scene(tmp)
    out, hid, info = reach(s, poses, ["radii"], (0.001, 0.005), 4, tmp, "atbound", rfun=smooth_r(0.001, 0.004, V),
                           radius=(0.002, 0.002), grav=[0, 0, -9.81])
    out["radius"] = [0.0021, 0.0021]
    out["design"]["radius_bounds"] = [0.0019, 0.0021]
    return out, hid, info


def c_wide_init_min(tmp):
    """hex sheet 3x3 K=4, left side held, gravity; bounds [0.3, 20] mm, the
    initial design AT the lower bound 0.3 mm (very floppy: large sag); hidden
    radii 1.5-4 mm; radii only; reachable."""
    s = grid("hex", (0.12, 0.1), (3, 3), 4, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(L)),
             dict(name="load", weight=1.0, fixed=fixed_list(L),
                  forces=[dict(vertex=i, force=[0, 0, -0.05 / len(R)]) for i in R])]
    out, hid, info = reach(s, poses, ["radii"], (0.0003, 0.02), 4, tmp, "widemin", rfun=smooth_r(0.0015, 0.004, V),
                           grav=[0, 0, -9.81])
    out["radius"] = [0.0003, 0.0003]
    return out, hid, info


def c_soft_1e5(tmp):
    """hex sheet 3x2 K=4, E = 1e5 Pa, hanging from the two top corners
    (fixed), gravity (large sag); pose 2 adds 2e-3 N sideways at the bottom
    centre; radii only, bounds [0.5, 8] mm, initial 3 mm; reachable."""
    s = grid("hex", (0.1, 0.08), (3, 2), 4, tmp)
    s["material"] = dict(young_modulus=1e5, poisson_ratio=0.45, density=1100.0)
    V = np.array(s["vertices"])
    con, _ = connections(s)
    c1 = nearest(V, con, [V[:, 0].min(), V[:, 1].max(), 0]); c2 = nearest(V, con, [V[:, 0].max(), V[:, 1].max(), 0])
    bot = nearest(V, range(len(V)), [0, V[:, 1].min(), 0])
    poses = [dict(name="hang", weight=1.0, fixed=fixed_list([c1, c2])),
             dict(name="hang_push", weight=1.0, fixed=fixed_list([c1, c2]), forces=[dict(vertex=bot, force=[2e-3, 0, 0])])]
    return reach(s, poses, ["radii"], (0.0005, 0.008), 4, tmp, "soft5", rfun=smooth_r(0.002, 0.005, V),
                 radius=(0.003, 0.003), grav=[0, -9.81, 0])


def c_stiff_1e11_dense(tmp):
    """quad strip 8x2 K=4 (0.16 x 0.04 m), E = 1e11 Pa, density 1e5 kg/m^3
    (the maximum), gravity; left clamped; pose 2 adds 200 N down at the right
    side; radii and rest shape, bounds [0.5, 10] mm; reachable."""
    s = grid("quad", (0.16, 0.04), (8, 2), 4, tmp)
    s["material"] = dict(young_modulus=1e11, poisson_ratio=0.3, density=1e5)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="sag", weight=1.0, clamped=[dict(vertex=i) for i in L]),
             dict(name="load", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  forces=[dict(vertex=i, force=[0, 0, -200.0 / len(R)]) for i in R])]
    return reach(s, poses, ["radii", "rest_shape"], (0.0005, 0.01), 4, tmp, "stiff11",
                 rfun=smooth_r(0.0008, 0.003, V), dfun=smooth_d(0.002, V), grav=[0, 0, -9.81])


def c_tri_big(tmp):
    """large tri sheet ~ 600 vertices (0.27 x 0.27, 9x9 cells... K=3),
    bottom held, gravity; top lifted 20 mm; radii only; reachable."""
    s = grid("tri", (0.27, 0.27), (9, 9), 4, tmp)
    V = np.array(s["vertices"])
    _, _, B, T = sides(V)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(B)),
             dict(name="lift", weight=1.0, fixed=fixed_list(B) + fixed_list(T, V[T] + [0, 0, 0.02]))]
    return reach(s, poses, ["radii"], (0.001, 0.005), 4, tmp, "tribig", rfun=smooth_r(0.0015, 0.0045, V),
                 grav=[0, 0, -9.81])


def c_bent_copy(tmp):
    """quad sheet 4x2 K=4 held along its centre line (x = 0 rod), gravity;
    target: the rest shape bent into a drooping cylinder (z = -x^2/(2*0.15)),
    a scaled copy 0.98 in y; rest shape only; unreachable (geometric)."""
    s = grid("quad", (0.16, 0.08), (4, 2), 4, tmp)
    V = np.array(s["vertices"])
    C = held_ids(V, np.abs(V[:, 0]) < 1e-6)
    poses = [dict(name="droop", weight=1.0, fixed=fixed_list(C))]
    T = V.copy()
    Rb = 0.15
    T[:, 0] = Rb * np.sin(V[:, 0] / Rb)
    T[:, 2] = -Rb * (1 - np.cos(V[:, 0] / Rb))
    T[:, 1] *= 0.98
    T[C] = V[C]
    return finish_geometric(s, poses, dict(droop=T), ["rest_shape"], (0.001, 0.005), 4, grav=[0, 0, -9.81])


def c_quad_hinge_gravity(tmp):
    """quad sheet 3x2 K=4 held (fixed, positions only) along its straight
    left side: a hinge, the sheet free to swing about it; gravity only;
    target: the rest shape swung 90 deg down about the hinge (hanging);
    radii only."""
    s = grid("quad", (0.09, 0.06), (3, 2), 4, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    x0 = V[:, 0].min()
    T = rot(V, np.array([x0, 0, 0]), [0, 1, 0], math.radians(90))
    poses = [dict(name="hang", weight=1.0, fixed=fixed_list(L))]
    return finish_geometric(s, poses, dict(hang=T), ["radii"], (0.001, 0.005), 4, grav=[0, 0, -9.81])


CASES = [
    ("hex452_corners", c_hex452_corners, True),
    ("quad_single_clamp", c_quad_single_clamp, True),
    ("ms_radii", c_ms_radii, False),
    ("ms_rest", c_ms_rest, False),
    ("ms_both", c_ms_both, False),
    ("comb_moments", c_comb_moments, True),
    ("strip_roll180", c_strip_roll180, True),
    ("strip_twist180", c_strip_twist180, False),
    ("tri_stretch", c_tri_stretch, True),
    ("quad_six_poses", c_quad_six_poses, True),
    ("zero_start", c_zero_start, False),
    ("grav_target_rest", c_grav_target_rest, False),
    ("rods2_tri", c_rods2_tri, True),
    ("rods2_quad_cp2", c_rods2_quad_cp2, True),
    ("quad_k25_cp10", c_quad_k25_cp10, True),
    ("planar_inplane", c_planar_inplane, True),
    ("nearly_planar", c_nearly_planar, True),
    ("tight_bounds", c_tight_bounds, True),
    ("init_at_bound", c_init_at_bound, False),
    ("wide_init_min", c_wide_init_min, True),
    ("soft_1e5", c_soft_1e5, True),
    ("stiff_1e11_dense", c_stiff_1e11_dense, True),
    ("tri_big", c_tri_big, True),
    ("bent_copy", c_bent_copy, False),
    ("quad_hinge_gravity", c_quad_hinge_gravity, False),
]


# ------------------------------------------------------------ batch 2
def _planar_t(tmp, eps):
    s = grid("tri", (0.15, 0.1), (5, 3), 4, tmp)
    V = np.array(s["vertices"])
    if eps:
        rng = np.random.default_rng(11)
        V[:, 2] += eps * rng.standard_normal(len(V))
        s["vertices"] = V.tolist()
    L, R, B, T = sides(V, 1e-5)
    corner = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="stretch", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0.006, 0.002, 0])),
             dict(name="pull", weight=1.0, fixed=fixed_list(L), forces=[dict(vertex=corner, force=[0.3, 0.1, 0])])]
    return s, V, poses


def c_planar_tension(tmp):
    """planar tri sheet 5x3 K=4, in-plane loads that do not buckle (right
    side pulled 6 mm in x, 2 mm in y; in-plane corner force 0.3/0.1 N);
    radii and rest shape (in-plane hidden displacement); reachable; in-plane
    solve."""
    s, V, poses = _planar_t(tmp, 0.0)
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "ptens",
                 rfun=smooth_r(0.0012, 0.0045, V), dfun=smooth_d(0.003, V, comps=(0, 1)))


def c_nearly_planar_tension(tmp):
    """planar_tension with z perturbed by 1e-6 m (3D scene)."""
    s, V, poses = _planar_t(tmp, 1e-6)
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "nptens",
                 rfun=smooth_r(0.0012, 0.0045, V), dfun=smooth_d(0.003, V, comps=(0, 1)))


def c_strip_inplane_rot90(tmp):
    """planar quad strip 10x1 K=4 (0.3 x 0.03 m), left clamped; the right
    handle (last half cell) prescribed onto an IN-PLANE arc, rotated 90 deg
    about z (pose 1) and 45 deg (pose 2); radii and rest shape (in plane);
    reachable; planar scene."""
    s, V, x0, x1, L, R = _strip_handle(tmp)
    poses = []
    for deg in (90, 45):
        phi = math.radians(deg)
        rho = (x1 - x0) / phi
        P = rot(V[R] - [x1, 0, 0], np.zeros(3), [0, 0, 1], phi) + [x0 + rho * math.sin(phi), rho * (1 - math.cos(phi)), 0]
        poses.append(dict(name="inplane%d" % deg, weight=1.0, clamped=[dict(vertex=i) for i in L], fixed=fixed_list(R, P)))
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "ip90",
                 rfun=smooth_r(0.0015, 0.004, V), dfun=smooth_d(0.002, V, comps=(0, 1)))


def c_strip_rot170(tmp):
    """strip of strip_roll180; handle rolled 170 deg about y and twisted
    170 deg about the strip axis (near the 180 deg collapse of the linear
    load path); radii and rest shape; reachable."""
    s, V, x0, x1, L, R = _strip_handle(tmp)
    a = math.radians(170)
    poses = [dict(name="roll170", weight=1.0, clamped=[dict(vertex=i) for i in L], fixed=fixed_list(R, roll(V, R, x0, x1, a))),
             dict(name="twist170", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  fixed=fixed_list(R, rot(V[R], np.zeros(3), [1, 0, 0], a)))]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "rot170",
                 rfun=smooth_r(0.0015, 0.004, V), dfun=smooth_d(0.002, V, comps=(0, 1)))


def c_comb_5poses(tmp):
    """planar comb (4 teeth of 21 vertices, no normals), initial radius 3 mm,
    root clamped, gravity; 5 poses: twisting moments +4e-3 / -4e-3 N m at the
    tips, 0.08 N down at the tips, 0.04 N along x at the tips (weight 0),
    gravity only; control_points_per_rod 2; radii and rest shape (3D hidden
    rest displacement); reachable."""
    s, root, tips, tail = comb_scene()
    V = np.array(s["vertices"])
    cl = [dict(vertex=root)]
    poses = [dict(name="twist_p", weight=1.0, clamped=cl, twisting_moments=[dict(vertex=t, moment=4e-3) for t in tips]),
             dict(name="twist_m", weight=1.0, clamped=cl, twisting_moments=[dict(vertex=t, moment=-4e-3) for t in tips]),
             dict(name="bend", weight=1.0, clamped=cl, forces=[dict(vertex=t, force=[0, 0, -0.08]) for t in tips]),
             dict(name="side0", weight=0.0, clamped=cl, forces=[dict(vertex=t, force=[0.04, 0, 0]) for t in tips]),
             dict(name="grav", weight=1.0, clamped=cl)]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.006), 2, tmp, "comb5",
                 rfun=smooth_r(0.0025, 0.0045, V), dfun=smooth_d(0.003, V), radius=(0.003, 0.003), grav=[0, 0, -9.81])


def c_rigid_rot90(tmp):
    """planar quad sheet 3x3 K=4; left and right sides prescribed rigidly
    rotated 90 deg about z around the centre (the linear load path shrinks
    the sheet to 0.71 at half load); target the rigidly rotated rest shape
    (stress-free, reached by the initial design if the path returns);
    radii only."""
    s = grid("quad", (0.09, 0.09), (3, 3), 4, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    H = L + R
    T = rot(V, np.zeros(3), [0, 0, 1], math.radians(90))
    poses = [dict(name="rot90", weight=1.0, fixed=fixed_list(H, T[H]))]
    return finish_geometric(s, poses, dict(rot90=T), ["radii"], (0.001, 0.005), 4)


def c_hex615_both(tmp):
    """large hex sheet 7x7 K=5 (615 v), bottom held, gravity; top lifted
    25 mm; radii and rest shape; reachable."""
    s = grid("hex", (0.36, 0.36), (7, 7), 5, tmp)
    V = np.array(s["vertices"])
    _, _, B, T = sides(V)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(B)),
             dict(name="lift", weight=1.0, fixed=fixed_list(B) + fixed_list(T, V[T] + [0, 0, 0.025]))]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.006), 4, tmp, "hex615",
                 rfun=smooth_r(0.002, 0.005, V), dfun=smooth_d(0.003, V), radius=(0.003, 0.003), grav=[0, 0, -9.81])


def c_scaled_copy_rest(tmp):
    """quad sheet 4x3 K=4, left held, right side prescribed +5% of the width
    in x; target: the rest shape scaled 1.05 in x about the left side (a
    stress-free rest shape reaches it exactly); rest shape only."""
    s = grid("quad", (0.12, 0.09), (4, 3), 4, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    x0 = V[:, 0].min()
    T = V.copy(); T[:, 0] = x0 + 1.05 * (V[:, 0] - x0)
    poses = [dict(name="stretch", weight=1.0, fixed=fixed_list(L) + fixed_list(R, T[R]))]
    return finish_geometric(s, poses, dict(stretch=T), ["rest_shape"], (0.001, 0.005), 4)


def c_ms_soft_large(tmp):
    """hex sheet 3x3 K=4, E = 1e6 Pa, held at the top side, gravity in -z
    (large sag) and a pose with 0.02 N pulling the bottom corners down;
    targets from the mass-spring model; radii and rest shape; unreachable."""
    s = grid("hex", (0.12, 0.1), (3, 3), 4, tmp)
    s["material"] = dict(young_modulus=1e6, poisson_ratio=0.45, density=1100.0)
    s["radius"] = [0.002, 0.002]
    s["gravity"] = [0, 0, -9.81]
    V = np.array(s["vertices"])
    _, _, B, T = sides(V)
    con, _ = connections(s)
    b1 = nearest(V, con, [V[:, 0].min(), V[:, 1].min(), 0]); b2 = nearest(V, con, [V[:, 0].max(), V[:, 1].min(), 0])
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(T)),
             dict(name="pull", weight=1.0, fixed=fixed_list(T), forces=[dict(vertex=b, force=[0, 0, -0.01]) for b in (b1, b2)])]
    Tg = mass_spring(s, poses, bend_factor=1.0)
    return finish_geometric(s, poses, Tg, ["radii", "rest_shape"], (0.0005, 0.008), 4, grav=[0, 0, -9.81])


def c_stiff_1e11_tiny(tmp):
    """quad sheet 3x3 K=4, E = 1e11 Pa, left clamped; 1e-3 N forces at the
    right side (nanometre displacements); rest shape only with a 0.5 mm
    hidden rest displacement; bounds [0.01, 50] mm; reachable."""
    s = grid("quad", (0.09, 0.09), (3, 3), 4, tmp)
    s["material"] = dict(young_modulus=1e11, poisson_ratio=0.3, density=7800.0)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="down", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  forces=[dict(vertex=i, force=[0, 0, -1e-3 / len(R)]) for i in R]),
             dict(name="side", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  forces=[dict(vertex=i, force=[0, 1e-3 / len(R), 0]) for i in R])]
    return reach(s, poses, ["rest_shape"], (0.00001, 0.05), 4, tmp, "tiny11", dfun=smooth_d(0.0005, V))


def c_rods2_hex_rest(tmp):
    """hex sheet 4x3 with 2-vertex rods (1 edge each), left side held,
    gravity; pose 2 right side pushed 5 mm up; rest shape only (3D hidden
    displacement); control_points_per_rod 4; reachable."""
    s = grid("hex", (0.12, 0.1), (4, 3), 2, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(L)),
             dict(name="up", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0, 0.005]))]
    return reach(s, poses, ["rest_shape"], (0.001, 0.005), 4, tmp, "rods2h", dfun=smooth_d(0.003, V), grav=[0, 0, -9.81])


def c_pivot_corner_hang(tmp):
    """quad sheet 3x3 K=4 held (fixed, positions only) at ONE corner
    connection: a pivot, free to swing; gravity; the sheet swings down
    (large rigid rotation); pose 2 adds 0.01 N in +y at the opposite corner;
    radii and rest shape; reachable."""
    s = grid("quad", (0.09, 0.09), (3, 3), 4, tmp)
    V = np.array(s["vertices"])
    con, _ = connections(s)
    c = nearest(V, con, [V[:, 0].min(), V[:, 1].min(), 0])
    o = nearest(V, con, [V[:, 0].max(), V[:, 1].max(), 0])
    poses = [dict(name="hang", weight=1.0, fixed=fixed_list([c])),
             dict(name="hang_push", weight=1.0, fixed=fixed_list([c]), forces=[dict(vertex=o, force=[0, 0.01, 0])])]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "pivot",
                 rfun=smooth_r(0.0015, 0.004, V), dfun=smooth_d(0.002, V), grav=[0, 0, -9.81])


CASES += [
    ("planar_tension", c_planar_tension, True),
    ("nearly_planar_tension", c_nearly_planar_tension, True),
    ("strip_inplane_rot90", c_strip_inplane_rot90, True),
    ("strip_rot170", c_strip_rot170, True),
    ("comb_5poses", c_comb_5poses, True),
    ("rigid_rot90", c_rigid_rot90, False),
    ("scaled_copy_rest", c_scaled_copy_rest, False),
    ("ms_soft_large", c_ms_soft_large, False),
    ("stiff_1e11_tiny", c_stiff_1e11_tiny, True),
    ("rods2_hex_rest", c_rods2_hex_rest, True),
    ("pivot_corner_hang", c_pivot_corner_hang, True),
    ("hex615_both", c_hex615_both, True),
]


# ------------------------------------------------------------ batch 3
def c_pivot_hang_only(tmp):
    """pivot_corner_hang's sheet, the 'hang' pose alone (one corner fixed,
    gravity, swings down; free spin about the vertical); radii and rest
    shape; reachable."""
    out, hid, info = c_pivot_corner_hang(tmp)
    out["poses"] = out["poses"][:1]
    hid["poses"] = hid["poses"][:1]
    return out, hid, info


def c_cp10_k3(tmp):
    """tri sheet 4x3 with 3-vertex rods (2 edges) and control_points_per_rod
    10 (more control points than vertices); left held, gravity; right lifted
    10 mm; radii and rest shape; reachable."""
    s = grid("tri", (0.12, 0.1), (4, 3), 3, tmp)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(L)),
             dict(name="lift", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0, 0.01]))]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 10, tmp, "cp10k3",
                 rfun=smooth_r(0.0015, 0.0045, V), dfun=smooth_d(0.002, V), grav=[0, 0, -9.81])


def c_strip_tip_large(tmp):
    """quad strip 10x1 K=4 (0.3 x 0.03), left clamped; tip forces: 1.5 N down
    (rotation past 90 deg) and 0.3 N along -x (compression beyond the
    cantilever's buckling load, with 0.01 N down to pick a branch); radii
    only; reachable."""
    s, V, x0, x1, L, R = _strip_handle(tmp)
    Rs = held_ids(V, V[:, 0] > x1 - 1e-6)
    poses = [dict(name="down", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  forces=[dict(vertex=i, force=[0, 0, -1.5 / len(Rs)]) for i in Rs]),
             dict(name="push", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  forces=[dict(vertex=i, force=[-0.3 / len(Rs), 0, -0.01 / len(Rs)]) for i in Rs])]
    return reach(s, poses, ["radii"], (0.001, 0.005), 4, tmp, "tiplarge", rfun=smooth_r(0.0015, 0.004, V))


def c_soft_1e5_drape(tmp):
    """hex sheet 3x3 K=4, E = 1e5 Pa, left side clamped, gravity -z: the
    sheet drapes down; pose 2 adds 2e-3 N up at the right side; radii and
    rest shape; reachable."""
    s = grid("hex", (0.12, 0.1), (3, 3), 4, tmp)
    s["material"] = dict(young_modulus=1e5, poisson_ratio=0.45, density=1100.0)
    V = np.array(s["vertices"])
    L, R, _, _ = sides(V)
    poses = [dict(name="drape", weight=1.0, clamped=[dict(vertex=i) for i in L]),
             dict(name="drape_lift", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  forces=[dict(vertex=i, force=[0, 0, 2e-3 / len(R)]) for i in R])]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.008), 4, tmp, "drape",
                 rfun=smooth_r(0.003, 0.006, V), dfun=smooth_d(0.003, V), radius=(0.004, 0.004), grav=[0, 0, -9.81])


def c_brush_rods2(tmp):
    """brush: a backbone along x (rods of 4 vertices) with 8 bristles that
    are single-edge rods (2 vertices, free ends), no normals; root clamped;
    pose 1 twisting moments 1e-4 N m on the bristles; pose 2 0.02 N down at
    the bristle tips; radii and rest shape; reachable."""
    Vs, rods = [], []

    def add(p):
        Vs.append([float(x) for x in p]); return len(Vs) - 1
    root = add([0, 0, 0]); prev = root; tips = []
    for t in range(8):
        j = add([0.02 * (t + 1), 0, 0])
        a = add([0.02 * (t + 1) - 0.0066, 0, 0]); b = add([0.02 * (t + 1) - 0.0133, 0, 0])
        rods.append(dict(vertices=[prev, b, a, j]))
        tip = add([0.02 * (t + 1), 0.03 * (1 if t % 2 else -1), 0])
        rods.append(dict(vertices=[j, tip]))
        tips.append(tip); prev = j
    m1 = add([0.1667, 0, 0]); m2 = add([0.1733, 0, 0]); tail = add([0.18, 0, 0])
    rods.append(dict(vertices=[prev, m1, m2, tail]))
    s = dict(format="rodmesh-scene/1", material=dict(young_modulus=3.2e7, poisson_ratio=0.48, density=1200.0),
             vertices=Vs, rods=rods)
    V = np.array(Vs)
    poses = [dict(name="twist", weight=1.0, clamped=[dict(vertex=root)],
                  twisting_moments=[dict(vertex=t, moment=1e-4) for t in tips]),
             dict(name="load", weight=1.0, clamped=[dict(vertex=root)], forces=[dict(vertex=t, force=[0, 0, -0.02]) for t in tips])]
    return reach(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "brush",
                 rfun=smooth_r(0.0015, 0.004, V), dfun=smooth_d(0.002, V))


def c_corners_clamped_5poses(tmp):
    """quad sheet 4x4 K=4 with its 4 corner connections clamped, gravity; 5
    poses: gravity only; 0.5 N down at the centre; 0.5 N up (weight 0);
    0.3 N sideways in plane at the centre; 0.2 N down at one edge midpoint
    (weight 2); radii only; reachable."""
    s = grid("quad", (0.12, 0.12), (4, 4), 4, tmp)
    V = np.array(s["vertices"])
    con, _ = connections(s)
    mn, mx = V.min(0), V.max(0)
    C = sorted({nearest(V, con, [x, y, 0]) for x in (mn[0], mx[0]) for y in (mn[1], mx[1])})
    ctr = nearest(V, con, [0, 0, 0]); em = nearest(V, con, [mx[0], 0, 0])
    cl = [dict(vertex=i) for i in C]
    poses = [dict(name="grav", weight=1.0, clamped=cl),
             dict(name="down", weight=1.0, clamped=cl, forces=[dict(vertex=ctr, force=[0, 0, -0.5])]),
             dict(name="up0", weight=0.0, clamped=cl, forces=[dict(vertex=ctr, force=[0, 0, 0.5])]),
             dict(name="side", weight=1.0, clamped=cl, forces=[dict(vertex=ctr, force=[0.3, 0, 0])]),
             dict(name="edge", weight=2.0, clamped=cl, forces=[dict(vertex=em, force=[0, 0, -0.2])])]
    return reach(s, poses, ["radii"], (0.001, 0.005), 4, tmp, "corners5", rfun=smooth_r(0.0015, 0.0045, V),
                 grav=[0, 0, -9.81])


CASES += [
    ("pivot_hang_only", c_pivot_hang_only, True),
    ("cp10_k3", c_cp10_k3, True),
    ("strip_tip_large", c_strip_tip_large, True),
    ("soft_1e5_drape", c_soft_1e5_drape, True),
    ("brush_rods2", c_brush_rods2, True),
    ("corners_clamped_5poses", c_corners_clamped_5poses, True),
]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rodmesh", default=BIN)
    ap.add_argument("--out", required=True)
    ap.add_argument("--only", default="")
    a = ap.parse_args()
    ms.RODMESH = os.path.abspath(a.rodmesh)
    return ms.write_cases(CASES, a.out, a.only, lambda fn, tmp: fn(tmp), unsolved_initial_ok=True)


if __name__ == "__main__":
    sys.exit(main())
