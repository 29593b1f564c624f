#!/usr/bin/python3
"""Acceptance-sweep scenes for rodmesh (different from benchmarks/defaults and
benchmarks/other_model).

    /usr/bin/python3 benchmarks/sweep/make_sweep.py --rodmesh BIN --out DIR [--only a,b]

Writes OUT/CASE.json (scene with targets and a design block), OUT/CASE.hidden.json
(the perturbed design whose equilibria are the targets, for reachable cases),
OUT/surfaces/*.obj and OUT/cases.json (index: vertices, poses, parameters,
reachable or not, description).

Reachable targets: a hidden design inside the design space (control values at
the control points, Bernstein interpolation per rod as docs/optimization.md)
simulated with `rodmesh simulate`; its equilibria are the targets.
Unreachable targets: geometric maps of the rest shape.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

RODMESH = "rodmesh"

# The study's helpers (benchmarks/study): simulate and its Failure, the
# design space's Bernstein weights and arc fractions.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "study"))
from make_scenes import Failure, simulate as study_simulate  # noqa: E402
from sweeps_scenes import bernstein, rod_arc_fractions  # noqa: E402


# ------------------------------------------------------------------ helpers
def run(cmd):
    r = subprocess.run([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise Failure("%s failed (exit %d): %s" % (" ".join(map(str, cmd)), r.returncode, r.stderr[-2000:]))
    return r


def simulate(scene, tmp, tag, require=True):
    """{pose name: positions} of every pose (benchmarks/study/make_scenes.py)."""
    return {name: q for name, (q, _) in study_simulate(RODMESH, scene, tmp, tag, require).items()}


def base_from_mesh_output(path):
    s = json.load(open(path))
    for k in ("design", "poses", "gravity"):
        s.pop(k, None)
    return s


def grid(kind, size, cells, k, tmp, extra=()):
    path = os.path.join(tmp, "grid_%s_%dx%d_%d.json" % (kind, cells[0], cells[1], k))
    run([RODMESH, "mesh", "--grid", kind, "--size", size[0], size[1], "--cells", cells[0], cells[1],
         "--rod-vertices", k, "-o", path, "-q"] + list(extra))
    return base_from_mesh_output(path)


def surface(obj, cells, tmp, edge, extra=()):
    path = os.path.join(tmp, os.path.basename(obj)[:-4] + "_%d.json" % cells)
    run([RODMESH, "mesh", obj, "--cells", cells, "--edge-length", edge, "-o", path, "-q"] + list(extra))
    return base_from_mesh_output(path)


def write_obj(path, V, F):
    with open(path, "w") as f:
        for v in V:
            f.write("v %.9g %.9g %.9g\n" % tuple(v))
        for t in F:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))


def param_grid(nu, nv, fn):
    """Triangulated (u, v) in [0,1]^2 grid mapped by fn(u, v) -> xyz."""
    V, F = [], []
    for j in range(nv + 1):
        for i in range(nu + 1):
            V.append(fn(i / nu, j / nv))
    for j in range(nv):
        for i in range(nu):
            a = j * (nu + 1) + i
            b, c, d = a + 1, a + nu + 1, a + nu + 2
            if (i + j) % 2:
                F += [(a, b, d), (a, d, c)]
            else:
                F += [(a, b, c), (b, d, c)]
    return np.array(V, float), F


def dome_obj(path, R=0.09, h=0.045, nr=14, nt=40):
    # spherical cap of base radius R and height h
    Rs = (R * R + h * h) / (2 * h)
    th_max = math.asin(R / Rs)
    V = [[0.0, 0.0, h]]
    for i in range(1, nr + 1):
        th = th_max * i / nr
        for j in range(nt):
            ph = 2 * math.pi * j / nt
            V.append([Rs * math.sin(th) * math.cos(ph), Rs * math.sin(th) * math.sin(ph), h - Rs * (1 - math.cos(th))])
    F = []
    for j in range(nt):
        F.append((0, 1 + j, 1 + (j + 1) % nt))
    for i in range(nr - 1):
        a, b = 1 + i * nt, 1 + (i + 1) * nt
        for j in range(nt):
            j1 = (j + 1) % nt
            F += [(a + j, b + j, b + j1), (a + j, b + j1, a + j1)]
    write_obj(path, V, F)


def cylinder_obj(path, L=0.16, Rc=0.05, angle=math.pi):
    # cylinder patch, axis x, spanning `angle` around the axis, apex up
    V, F = param_grid(32, 24, lambda u, v: [L * (u - 0.5), Rc * math.sin(angle * (v - 0.5)),
                                            Rc * math.cos(angle * (v - 0.5))])
    write_obj(path, V, F)


def saddle_obj(path, W=0.16, a=0.12):
    V, F = param_grid(30, 30, lambda u, v: [W * (u - 0.5), W * (v - 0.5),
                                            ((W * (u - 0.5)) ** 2 - (W * (v - 0.5)) ** 2) / (2 * a)])
    write_obj(path, V, F)


# design space: Bernstein per rod, control points at arc fractions j/(n-1)
# (imported above from benchmarks/study/sweeps_scenes.py)


def arc_fractions(V, rod):
    return rod_arc_fractions(V, rod)


def hidden(scene, n, rfun=None, dfun=None):
    """Per-vertex radii and rest positions of a hidden design inside the design
    space: control values rfun(p) -> (r_t, r_n), dfun(p) -> (dx, dy, dz) at the
    control points' rest positions p."""
    V = np.asarray(scene["vertices"], float)
    r0 = scene.get("radius", [0.002, 0.002])
    radii = np.tile(np.asarray(r0, float), (len(V), 1))
    rest = V.copy()
    c = np.linspace(0, 1, n)
    for rod in scene["rods"]:
        s = arc_fractions(V, rod)
        P = V[rod["vertices"]]
        cp = np.stack([np.interp(c, s, P[:, k]) for k in range(3)], 1)
        cp[0], cp[-1] = P[0], P[-1]
        B = bernstein(n, s)
        idx = rod["vertices"]
        if rfun is not None:
            radii[idx] = B @ np.array([rfun(p) for p in cp])
        if dfun is not None:
            rest[idx] = V[idx] + B @ np.array([dfun(p) for p in cp])
    return radii, rest


def held_ids(V, mask):
    return [int(i) for i in np.where(mask)[0]]


def rot(points, centre, axis, ang):
    a = np.asarray(axis, float)
    a /= np.linalg.norm(a)
    p = np.asarray(points) - centre
    c, s = math.cos(ang), math.sin(ang)
    return centre + p * c + np.cross(a, p) * s + np.outer(p @ a, a) * (1 - c)


def fixed_list(ids, positions=None):
    if positions is None:
        return [dict(vertex=i) for i in ids]
    return [dict(vertex=i, position=[float(x) for x in p]) for i, p in zip(ids, positions)]


def finish_reachable(scene, poses, params, bounds, n, tmp, tag, rfun=None, dfun=None, radius=(0.002, 0.002),
                     grav=None):
    scene = dict(scene)
    scene["radius"] = list(radius)
    if grav is not None:
        scene["gravity"] = grav
    radii, rest = hidden(scene, n, rfun if "radii" in params else None, dfun if "rest_shape" in params else None)
    hid = dict(scene)
    hid.pop("radius", None)
    hid["vertices"] = rest.tolist()
    hid["radii"] = radii.tolist()
    hid["poses"] = poses
    q = simulate(hid, tmp, tag + "_hidden")
    out = dict(scene)
    out["poses"] = [dict(p, target=np.asarray(q[p["name"]]).tolist()) for p in poses]
    out["design"] = dict(parameters=list(params), radius_bounds=list(bounds), control_points_per_rod=n)
    info = dict(hidden_radii_mm=[round(1e3 * radii.min(), 3), round(1e3 * radii.max(), 3)],
                hidden_rest_disp_mm=round(1e3 * float(np.linalg.norm(rest - np.asarray(scene["vertices"]), axis=1).max()), 3))
    return out, hid, info


def finish_geometric(scene, poses, targets, params, bounds, n, radius=(0.002, 0.002), grav=None):
    scene = dict(scene)
    scene["radius"] = list(radius)
    if grav is not None:
        scene["gravity"] = grav
    out = dict(scene)
    out["poses"] = [dict(p, target=np.asarray(targets[p["name"]]).tolist()) for p in poses]
    out["design"] = dict(parameters=list(params), radius_bounds=list(bounds), control_points_per_rod=n)
    return out, None, {}


def smooth_r(lo, hi, V):
    """Radius function over the scene's bounding box, values in [lo, hi]."""
    V = np.asarray(V, float)
    mn, mx = V.min(0), V.max(0)
    ext = np.maximum(mx - mn, 1e-9)

    def f(p):
        u = (np.asarray(p) - mn) / ext
        a = 0.5 + 0.5 * math.sin(2.1 * u[0] + 1.3 * u[1] + 0.7 * u[2] + 0.3)
        b = 0.5 + 0.5 * math.cos(1.7 * u[0] - 2.3 * u[1] + 0.9 * u[2])
        return [lo + (hi - lo) * a, lo + (hi - lo) * b]
    return f


def smooth_d(amp, V, comps=(0, 1, 2)):
    V = np.asarray(V, float)
    mn, mx = V.min(0), V.max(0)
    ext = np.maximum(mx - mn, 1e-9)

    def f(p):
        u = (np.asarray(p) - mn) / ext
        d = [amp * math.sin(3.0 * u[1] + 1.1 * u[0]), amp * math.sin(2.5 * u[0] - 0.8 * u[2]),
             amp * math.cos(2.2 * u[0] + 1.9 * u[1])]
        return [d[k] if k in comps else 0.0 for k in range(3)]
    return f


# ------------------------------------------------------------------ cases
def c_quad_lift_radii(tmp, surf):
    """quad sheet 4x3 cells, K=4; left side held, right side lifted 30 mm (pose 1)
    and lifted + sheared in plane (pose 2); radii only; reachable."""
    s = grid("quad", (0.12, 0.09), (4, 3), 4, tmp)
    V = np.array(s["vertices"])
    L = held_ids(V, V[:, 0] < V[:, 0].min() + 1e-6)
    R = held_ids(V, V[:, 0] > V[:, 0].max() - 1e-6)
    poses = [dict(name="lift", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0, 0.03])),
             dict(name="lift_shear", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0.012, 0.015]))]
    return finish_reachable(s, poses, ["radii"], (0.0008, 0.006), 4, tmp, "quad_lift",
                            rfun=smooth_r(0.001, 0.0045, V))


def c_tri_shear_rest(tmp, surf):
    """tri sheet; bottom held, top prescribed in-plane shear; rest shape only
    (in-plane hidden rest displacement, 3 mm); reachable; 1 pose."""
    s = grid("tri", (0.12, 0.1), (4, 4), 4, tmp)
    V = np.array(s["vertices"])
    B = held_ids(V, V[:, 1] < V[:, 1].min() + 1e-6)
    T = held_ids(V, V[:, 1] > V[:, 1].max() - 1e-6)
    poses = [dict(name="shear", weight=1.0, fixed=fixed_list(B) + fixed_list(T, V[T] + [0.02, 0.0, 0.0]))]
    return finish_reachable(s, poses, ["rest_shape"], (0.001, 0.005), 4, tmp, "tri_shear",
                            dfun=smooth_d(0.003, V, comps=(0, 1)))


def c_hex_buckle_both(tmp, surf):
    """hex sheet; left held, right pushed 10% towards the left (compression
    that buckles) plus a tiny gravity to break symmetry; radii and rest shape;
    reachable (hidden rest displacement out of plane -> 3D scene)."""
    s = grid("hex", (0.13, 0.1), (3, 3), 5, tmp)
    V = np.array(s["vertices"])
    L = held_ids(V, V[:, 0] < V[:, 0].min() + 1e-6)
    R = held_ids(V, V[:, 0] > V[:, 0].max() - 1e-6)
    w = V[:, 0].max() - V[:, 0].min()
    poses = [dict(name="compress", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] - [0.1 * w, 0, 0]))]
    # rest displacement only in plane: the scene stays planar, the buckling is decided by rodmesh
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "hex_buckle",
                            rfun=smooth_r(0.0012, 0.004, V), dfun=smooth_d(0.002, V, comps=(0, 1)))


def c_dome_gravity_radii(tmp, surf):
    """dome (spherical cap) mesh ~ 30 cells, rim held, gravity only, soft
    material (E = 3e5 Pa), wide radius bounds; radii only; reachable."""
    s = surface(os.path.join(surf, "dome.obj"), 30, tmp, 0.01)
    s["material"] = dict(young_modulus=3e5, poisson_ratio=0.45, density=1100.0)
    V = np.array(s["vertices"])
    rim = held_ids(V, V[:, 2] < V[:, 2].min() + 1e-4)
    poses = [dict(name="gravity", weight=1.0, fixed=fixed_list(rim))]
    return finish_reachable(s, poses, ["radii"], (0.0003, 0.008), 4, tmp, "dome_grav",
                            rfun=smooth_r(0.0008, 0.005, V), radius=(0.003, 0.003), grav=[0, 0, -9.81])


def c_cyl_twist_unreach(tmp, surf):
    """half-cylinder patch (axis x); x = min end held; x = max end twisted 25 deg
    about the axis (pose 1) and pushed 15 mm along -x (pose 2); targets are
    geometric: a helicoidal twist growing linearly in x, and an axial shortening
    with bulge; radii and rest shape; unreachable."""
    s = surface(os.path.join(surf, "cyl.obj"), 40, tmp, 0.008)
    V = np.array(s["vertices"])
    x0, x1 = V[:, 0].min(), V[:, 0].max()
    A = held_ids(V, V[:, 0] < x0 + 1e-4)
    Bi = held_ids(V, V[:, 0] > x1 - 1e-4)
    ang = math.radians(25)
    tw = rot(V[Bi], np.zeros(3), [1, 0, 0], ang)
    poses = [dict(name="twist", weight=1.0, fixed=fixed_list(A) + fixed_list(Bi, tw)),
             dict(name="push", weight=1.0, fixed=fixed_list(A) + fixed_list(Bi, V[Bi] - [0.015, 0, 0]))]
    u = (V[:, 0] - x0) / (x1 - x0)
    T1 = np.array([rot(V[i:i + 1], np.zeros(3), [1, 0, 0], ang * u[i])[0] for i in range(len(V))])
    T2 = V.copy()
    T2[:, 0] = x0 + (V[:, 0] - x0) * (1 - 0.015 / (x1 - x0))
    bulge = 1 + 0.12 * np.sin(math.pi * u)
    T2[:, 1:] *= bulge[:, None]
    return finish_geometric(s, poses, dict(twist=T1, push=T2), ["radii", "rest_shape"], (0.001, 0.005), 4)


def c_saddle_forces_rest(tmp, surf):
    """saddle z = (x^2 - y^2)/(2a), ~40 cells; vertices near the centre held;
    point forces at the four corners: down at the high corners (pose 1),
    up at the low corners (pose 2); rest shape only; geometric targets: the
    saddle flattened to 50% and steepened to 150% height; unreachable."""
    s = surface(os.path.join(surf, "saddle.obj"), 40, tmp, 0.008)
    V = np.array(s["vertices"])
    ctr = held_ids(V, np.linalg.norm(V[:, :2], axis=1) < 0.02)
    corners = {}
    for sx in (-1, 1):
        for sy in (-1, 1):
            corners[(sx, sy)] = int(np.argmin(np.linalg.norm(V[:, :2] - [sx * 0.08, sy * 0.08], axis=1)))
    hi = [corners[(1, 1)], corners[(-1, -1)]] if V[corners[(1, 1)], 2] > 0 else []
    hi = [corners[(1, 1)], corners[(-1, 1)]]
    high = [c for c in corners.values() if V[c, 2] > 0]
    low = [c for c in corners.values() if V[c, 2] <= 0]
    poses = [dict(name="flatten", weight=1.0, fixed=fixed_list(ctr),
                  forces=[dict(vertex=c, force=[0, 0, -0.3]) for c in high]),
             dict(name="steepen", weight=2.0, fixed=fixed_list(ctr),
                  forces=[dict(vertex=c, force=[0, 0, -0.2]) for c in low])]
    T1 = V.copy(); T1[:, 2] *= 0.5
    T2 = V.copy(); T2[:, 2] *= 1.5
    T1[ctr] = V[ctr]; T2[ctr] = V[ctr]
    return finish_geometric(s, poses, dict(flatten=T1, steepen=T2), ["rest_shape"], (0.001, 0.005), 4)


def c_dome_scaled_unreach(tmp, surf):
    """dome ~ 20 cells; rim held; 3 poses: gravity, apex pushed down by a
    point force 0.5 N, rim prescribed outward 8 mm (radial stretch); targets
    the rest shape scaled (1.1 in xy, 0.85 in z; 0.9 / 1.2; 1.05 / 1.0):
    unreachable; radii and rest shape."""
    s = surface(os.path.join(surf, "dome.obj"), 20, tmp, 0.009)
    V = np.array(s["vertices"])
    rim = held_ids(V, V[:, 2] < V[:, 2].min() + 1e-4)
    apex = int(np.argmax(V[:, 2]))
    radial = V[rim].copy()
    rr = np.linalg.norm(radial[:, :2], axis=1)
    radial[:, :2] *= ((rr + 0.008) / rr)[:, None]
    poses = [dict(name="gravity", weight=1.0, fixed=fixed_list(rim)),
             dict(name="poke", weight=1.0, fixed=fixed_list(rim), forces=[dict(vertex=apex, force=[0, 0, -0.5])]),
             dict(name="stretch", weight=0.5, fixed=fixed_list(rim, radial))]

    def sc(a, b):
        T = V.copy(); T[:, :2] *= a; T[:, 2] = V[:, 2].min() + (V[:, 2] - V[:, 2].min()) * b
        return T
    T3 = sc(1.05, 1.0); T3[rim] = radial
    T1 = sc(1.1, 0.85); T1[rim] = V[rim]
    T2 = sc(0.9, 1.2); T2[rim] = V[rim]
    return finish_geometric(s, poses, dict(gravity=T1, poke=T2, stretch=T3), ["radii", "rest_shape"],
                            (0.001, 0.005), 4, grav=[0, 0, -9.81])


def c_strip_huge_tiny(tmp, surf):
    """long quad strip 8 x 1 cells, K=5; left side clamped; stiff material
    (E = 2.5e9, PLA-like); pose 'huge': 40 N down at the right side (large
    deflection), pose 'tiny': 1e-4 N (near linear); radii only, wide bounds
    [0.1, 20] mm; reachable."""
    s = grid("quad", (0.32, 0.04), (8, 1), 5, tmp)
    s["material"] = dict(young_modulus=2.5e9, poisson_ratio=0.35, density=1250.0)
    V = np.array(s["vertices"])
    L = held_ids(V, V[:, 0] < V[:, 0].min() + 1e-6)
    R = held_ids(V, V[:, 0] > V[:, 0].max() - 1e-6)
    poses = [dict(name="huge", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  forces=[dict(vertex=i, force=[0, 0, -40.0 / len(R)]) for i in R]),
             dict(name="tiny", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  forces=[dict(vertex=i, force=[0, 0, -1e-4 / len(R)]) for i in R])]
    return finish_reachable(s, poses, ["radii"], (0.0001, 0.02), 4, tmp, "strip",
                            rfun=smooth_r(0.0015, 0.0035, V))


def spider_scene():
    """hub-and-spokes 3D frame: 5 spokes from a hub to a ring (pentagon in
    z = 0.01), a pentagonal ring rod network, and 5 free tails beyond the ring
    pointing outward and up.  ~ 35 vertices."""
    Vs, rods = [[0.0, 0.0, 0.0]], []
    nsp, K = 5, 3
    ring = []
    for i in range(nsp):
        a = 2 * math.pi * i / nsp
        ring.append(len(Vs)); Vs.append([0.05 * math.cos(a), 0.05 * math.sin(a), 0.01])
    def line(a, b, k):
        ids = [a]
        for t in range(1, k - 1):
            f = t / (k - 1)
            ids.append(len(Vs)); Vs.append(list((1 - f) * np.array(Vs[a]) + f * np.array(Vs[b])))
        return ids + [b]
    for i in range(nsp):
        rods.append(dict(vertices=line(0, ring[i], K)))
    for i in range(nsp):
        rods.append(dict(vertices=line(ring[i], ring[(i + 1) % nsp], K)))
    tips = []
    for i in range(nsp):
        a = 2 * math.pi * i / nsp
        tip = len(Vs); Vs.append([0.08 * math.cos(a), 0.08 * math.sin(a), 0.03]); tips.append(tip)
        rods.append(dict(vertices=line(ring[i], tip, K)))
    return dict(format="rodmesh-scene/1", material=dict(young_modulus=3.2e7, poisson_ratio=0.48, density=1200.0),
                vertices=Vs, rods=rods), tips


def c_spider_moments(tmp, surf):
    """tiny 3D frame (hub, 5 spokes, pentagonal ring, 5 free tails, ~26
    vertices); hub clamped; pose 1 twisting moments 2e-4 N m at the tails'
    free ends; pose 2 the same plus gravity-like point forces; radii and rest
    shape; reachable; control_points_per_rod 3."""
    s, tips = spider_scene()
    hub = 0
    V = np.array(s["vertices"])
    poses = [dict(name="twist", weight=1.0, clamped=[dict(vertex=hub)],
                  twisting_moments=[dict(vertex=t, moment=2e-4) for t in tips]),
             dict(name="twist_load", weight=1.0, clamped=[dict(vertex=hub)],
                  twisting_moments=[dict(vertex=t, moment=-1e-4) for t in tips],
                  forces=[dict(vertex=t, force=[0, 0, -0.02]) for t in tips])]
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 3, tmp, "spider",
                            rfun=smooth_r(0.0012, 0.004, V), dfun=smooth_d(0.002, V))


def c_tri_four_poses(tmp, surf):
    """tri sheet 5x4, K=4 (~150 vertices); 4 poses: gravity sag with the left
    side held; right side lifted 20 mm; right side rotated 20 deg about x
    (twist); point force pulling the right-top corner in plane; radii and rest
    shape; reachable; gravity on."""
    s = grid("tri", (0.15, 0.12), (5, 4), 4, tmp)
    V = np.array(s["vertices"])
    L = held_ids(V, V[:, 0] < V[:, 0].min() + 0.012)
    R = held_ids(V, V[:, 0] > V[:, 0].max() - 0.012)
    c = V[R].mean(0)
    corner = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(L)),
             dict(name="lift", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] + [0, 0, 0.02])),
             dict(name="twist", weight=1.0, fixed=fixed_list(L) + fixed_list(R, rot(V[R], c, [1, 0, 0], math.radians(20)))),
             dict(name="pull", weight=1.0, fixed=fixed_list(L), forces=[dict(vertex=corner, force=[0.3, 0.2, 0.0])])]
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "tri4",
                            rfun=smooth_r(0.0012, 0.0042, V), dfun=smooth_d(0.003, V), grav=[0, 0, -9.81])


def c_saddle_stiff_radii(tmp, surf):
    """saddle ~ 70 cells (~400 vertices); stiff material E = 2e9, radii
    bounds [0.2, 10] mm, initial 1 mm; two corner edges held (x < -0.07);
    gravity + a 2 N point force at the far corner (pose 1); gravity only
    (pose 2); radii only; reachable."""
    s = surface(os.path.join(surf, "saddle.obj"), 70, tmp, 0.007)
    s["material"] = dict(young_modulus=2e9, poisson_ratio=0.35, density=1250.0)
    V = np.array(s["vertices"])
    H = held_ids(V, V[:, 0] < V[:, 0].min() + 0.012)
    far = int(np.argmax(V[:, 0]))
    poses = [dict(name="load", weight=1.0, fixed=fixed_list(H), forces=[dict(vertex=far, force=[0, 0, -2.0])]),
             dict(name="gravity", weight=1.0, fixed=fixed_list(H))]
    return finish_reachable(s, poses, ["radii"], (0.0002, 0.01), 4, tmp, "saddle_stiff",
                            rfun=smooth_r(0.0006, 0.003, V), radius=(0.001, 0.001), grav=[0, 0, -9.81])


def c_hex_oop_rest(tmp, surf):
    """planar hex sheet (3x2 cells, K=4, ~55 vertices) held at the bottom;
    gravity in -z plus top lifted 10 mm; rest shape only; targets from a
    hidden design with OUT-OF-PLANE rest displacement (5 mm): not reachable
    by a planar design (the design stays planar), but close."""
    s = grid("hex", (0.09, 0.07), (2, 2), 4, tmp)
    V = np.array(s["vertices"])
    B = held_ids(V, V[:, 1] < V[:, 1].min() + 1e-6)
    T = held_ids(V, V[:, 1] > V[:, 1].max() - 1e-6)
    poses = [dict(name="sag", weight=1.0, fixed=fixed_list(B)),
             dict(name="lift", weight=1.0, fixed=fixed_list(B) + fixed_list(T, V[T] + [0, 0, 0.01]))]
    s = dict(s)
    s["radius"] = [0.002, 0.002]
    s["gravity"] = [0, 0, -9.81]
    radii, rest = hidden(s, 4, None, smooth_d(0.005, V, comps=(2,)))
    hid = dict(s); hid.pop("radius"); hid["vertices"] = rest.tolist(); hid["radii"] = radii.tolist(); hid["poses"] = poses
    q = simulate(hid, tmp, "hex_oop_hidden")
    out = dict(s)
    out["poses"] = [dict(p, target=np.asarray(q[p["name"]]).tolist()) for p in poses]
    out["design"] = dict(parameters=["rest_shape"], radius_bounds=[0.001, 0.005], control_points_per_rod=4)
    return out, hid, dict(note="hidden rest displacement out of plane")


def c_big_quad_both(tmp, surf):
    """quad sheet 7x6 cells, K=5 (~ 400 vertices); bottom-left and
    bottom-right corners' bottom side held; centre of the top side pulled up
    by a 0.4 N point force (pose 1); whole top side prescribed 10 mm in -y
    (in-plane compression, pose 2); radii and rest shape; reachable."""
    s = grid("quad", (0.21, 0.18), (7, 6), 5, tmp)
    V = np.array(s["vertices"])
    B = held_ids(V, V[:, 1] < V[:, 1].min() + 1e-6)
    T = held_ids(V, V[:, 1] > V[:, 1].max() - 1e-6)
    top_c = int(np.argmin(np.linalg.norm(V - [0, V[:, 1].max(), 0], axis=1)))
    poses = [dict(name="pull_up", weight=1.0, fixed=fixed_list(B), forces=[dict(vertex=top_c, force=[0, 0, 0.4])]),
             dict(name="squeeze", weight=1.0, fixed=fixed_list(B) + fixed_list(T, V[T] - [0, 0.01, 0]))]
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "bigquad",
                            rfun=smooth_r(0.0012, 0.0042, V), dfun=smooth_d(0.003, V, comps=(0, 1)))


CASES = [
    ("quad_lift_radii", c_quad_lift_radii, True),
    ("tri_shear_rest", c_tri_shear_rest, True),
    ("hex_buckle_both", c_hex_buckle_both, True),
    ("dome_gravity_radii", c_dome_gravity_radii, True),
    ("cyl_twist_unreach", c_cyl_twist_unreach, False),
    ("saddle_forces_rest", c_saddle_forces_rest, False),
    ("dome_scaled_unreach", c_dome_scaled_unreach, False),
    ("strip_huge_tiny", c_strip_huge_tiny, True),
    ("spider_moments", c_spider_moments, True),
    ("tri_four_poses", c_tri_four_poses, True),
    ("saddle_stiff_radii", c_saddle_stiff_radii, True),
    ("hex_oop_rest", c_hex_oop_rest, False),
    ("big_quad_both", c_big_quad_both, True),
]


# ------------------------------------------------------------------ batch 2
def c_strip_column_buckle(tmp, surf):
    """planar quad strip 6 x 1 cells, K=5 (~70 vertices), left side held,
    right side prescribed 3% towards the left (a column that buckles out of
    plane), plus a second pose with 0.05 N pulling the right side; radii
    only; targets from a hidden radii design (simulate solves the buckled
    pose in 3D): reachable only out of plane."""
    s = grid("quad", (0.24, 0.04), (6, 1), 5, tmp)
    V = np.array(s["vertices"])
    L = held_ids(V, V[:, 0] < V[:, 0].min() + 1e-6)
    R = held_ids(V, V[:, 0] > V[:, 0].max() - 1e-6)
    w = V[:, 0].max() - V[:, 0].min()
    poses = [dict(name="column", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] - [0.03 * w, 0, 0])),
             dict(name="pull", weight=1.0, fixed=fixed_list(L), forces=[dict(vertex=i, force=[0.05 / len(R), 0, 0]) for i in R])]
    return finish_reachable(s, poses, ["radii"], (0.001, 0.005), 4, tmp, "column",
                            rfun=smooth_r(0.0015, 0.004, V))


def c_dome_snap(tmp, surf):
    """shallow dome (cap height 12 mm over radius 90 mm, ~150 vertices), rim
    held; pose 'snap': 6 N down at the apex (snap-through range), pose
    'gravity'; radii only; reachable from a hidden radii design (if its
    simulation converges)."""
    dome_obj(os.path.join(surf, "shallow.obj"), R=0.09, h=0.012)
    s = surface(os.path.join(surf, "shallow.obj"), 24, tmp, 0.01)
    V = np.array(s["vertices"])
    rim = held_ids(V, V[:, 2] < V[:, 2].min() + 1e-4)
    apex = int(np.argmax(V[:, 2]))
    near = held_ids(V, np.linalg.norm(V[:, :2] - V[apex, :2], axis=1) < 0.012)
    poses = [dict(name="snap", weight=1.0, fixed=fixed_list(rim), forces=[dict(vertex=i, force=[0, 0, -6.0 / len(near)]) for i in near]),
             dict(name="gravity", weight=1.0, fixed=fixed_list(rim))]
    return finish_reachable(s, poses, ["radii"], (0.001, 0.005), 4, tmp, "snap",
                            rfun=smooth_r(0.0015, 0.004, V), grav=[0, 0, -9.81])


def c_tent_nonormals(tmp, surf):
    """hand-built 3D tent frame without `normals` (4 legs from the ground to
    an apex, 4 ridge/base rods between leg midpoints? no: a square pyramid
    with a ring at mid height, ~45 vertices); feet held; gravity + 0.5 N side
    push on the apex; rest shape only; reachable (hidden 3D rest
    displacement)."""
    Vs, rods = [], []
    def add(p):
        Vs.append([float(x) for x in p]); return len(Vs) - 1
    def line(a, b, k):
        ids = [a]
        for t in range(1, k - 1):
            f = t / (k - 1)
            ids.append(add((1 - f) * np.array(Vs[a]) + f * np.array(Vs[b])))
        return ids + [b]
    apex = add([0, 0, 0.1])
    feet = [add([0.08 * math.cos(a), 0.08 * math.sin(a), 0.0]) for a in np.arange(4) * math.pi / 2 + math.pi / 4]
    mids = [add(0.5 * (np.array(Vs[f]) + np.array(Vs[apex]))) for f in feet]
    for f, m in zip(feet, mids):
        rods.append(dict(vertices=line(f, m, 4)))
        rods.append(dict(vertices=line(m, apex, 4)))
    for i in range(4):
        rods.append(dict(vertices=line(mids[i], mids[(i + 1) % 4], 5)))
    s = dict(format="rodmesh-scene/1", material=dict(young_modulus=5e6, poisson_ratio=0.45, density=1200.0),
             vertices=Vs, rods=rods)
    V = np.array(Vs)
    poses = [dict(name="gravity", weight=1.0, fixed=fixed_list(feet)),
             dict(name="push", weight=1.0, fixed=fixed_list(feet), forces=[dict(vertex=apex, force=[0.5, 0.2, 0])])]
    return finish_reachable(s, poses, ["rest_shape"], (0.001, 0.005), 4, tmp, "tent",
                            dfun=smooth_d(0.004, V), grav=[0, 0, -9.81])


def c_stiff_nano(tmp, surf):
    """quad sheet 3x3 cells, K=4, E = 1e12 Pa (very stiff), left side held,
    0.01 N at the right side (displacements of nanometres: near linear, tiny);
    second pose 10x the force; radii and rest shape; reachable."""
    s = grid("quad", (0.09, 0.09), (3, 3), 4, tmp)
    s["material"] = dict(young_modulus=1e12, poisson_ratio=0.3, density=7800.0)
    V = np.array(s["vertices"])
    L = held_ids(V, V[:, 0] < V[:, 0].min() + 1e-6)
    R = held_ids(V, V[:, 0] > V[:, 0].max() - 1e-6)
    poses = [dict(name="nano", weight=1.0, fixed=fixed_list(L), forces=[dict(vertex=i, force=[0, 0, -0.01 / len(R)]) for i in R]),
             dict(name="micro", weight=1.0, fixed=fixed_list(L), forces=[dict(vertex=i, force=[0, 0.05 / len(R), -0.1 / len(R)]) for i in R])]
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "nano",
                            rfun=smooth_r(0.0012, 0.004, V), dfun=smooth_d(0.0005, V))


def c_soft_thin_gravity(tmp, surf):
    """hex sheet 3x2 cells, K=5, very soft (E = 2e4 Pa) thin rods (initial
    0.5 mm, bounds [0.05, 10] mm), top side held, hanging under gravity
    (large sag) and a pose with gravity sideways (y); radii only;
    reachable."""
    s = grid("hex", (0.09, 0.08), (3, 2), 5, tmp)
    s["material"] = dict(young_modulus=2e4, poisson_ratio=0.49, density=1000.0)
    V = np.array(s["vertices"])
    T = held_ids(V, V[:, 1] > V[:, 1].max() - 1e-6)
    poses = [dict(name="hang", weight=1.0, fixed=fixed_list(T)),
             dict(name="hang_side", weight=1.0, fixed=fixed_list(T),
                  forces=[dict(vertex=int(i), force=[0.0, 0.0, -2e-4]) for i in range(len(V)) if i not in T][:10])]
    return finish_reachable(s, poses, ["radii"], (0.00005, 0.01), 4, tmp, "soft",
                            rfun=smooth_r(0.0003, 0.002, V), radius=(0.0005, 0.0005), grav=[0, -9.81, -3.0])


def c_strip_roll_twist(tmp, surf):
    """quad strip 6 x 1 cells, K=5; left side clamped; right side prescribed
    rotated 150 deg about the strip axis (large twist) and another pose 90 deg
    about y (rolled up); both parameters; geometric targets: the same strip
    twisted into a linear helicoid / bent into a circular arc (close to the
    mechanics, not exact)."""
    s = grid("quad", (0.24, 0.04), (6, 1), 5, tmp)
    V = np.array(s["vertices"])
    x0, x1 = V[:, 0].min(), V[:, 0].max()
    L = held_ids(V, V[:, 0] < x0 + 1e-6)
    R = held_ids(V, V[:, 0] > x1 - 1e-6)
    c = np.array([x1, 0, 0])
    ang = math.radians(150)
    poses = [dict(name="twist150", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  fixed=fixed_list(R, rot(V[R], c, [1, 0, 0], ang))),
             dict(name="roll90", weight=1.0, clamped=[dict(vertex=i) for i in L],
                  fixed=fixed_list(R, None))]
    # roll: arc of angle 90 deg of the same length, right side placed on it
    Ls = x1 - x0
    rho = Ls / (math.pi / 2)
    def arc(p):
        t = (p[0] - x0) / rho
        return [x0 + rho * math.sin(t), p[1], rho * (1 - math.cos(t))]
    T2 = np.array([arc(p) for p in V])
    Rpos = T2[R]
    # right side rotated by 90 deg about y as the arc's end orientation
    poses[1]["fixed"] = fixed_list(R, Rpos)
    u = (V[:, 0] - x0) / Ls
    T1 = np.array([rot(V[i:i + 1], np.array([0, 0, 0]), [1, 0, 0], ang * u[i])[0] for i in range(len(V))])
    T1[R] = rot(V[R], c, [1, 0, 0], ang)
    return finish_geometric(s, poses, dict(twist150=T1, roll90=T2), ["radii", "rest_shape"], (0.001, 0.005), 4)


def c_cyl_free_boundary(tmp, surf):
    """cylinder patch meshed with --boundary free (free rod ends), ~25 cells;
    the x-min end held; 3 poses: gravity; twisting moments 1e-4 N m at all free
    ends; lift of the x-max end by 20 mm (prescribed); radii and rest shape;
    reachable; control_points_per_rod 5."""
    s = surface(os.path.join(surf, "cyl.obj"), 25, tmp, 0.009, extra=["--boundary", "free"])
    V = np.array(s["vertices"])
    x0, x1 = V[:, 0].min(), V[:, 0].max()
    ends = {}
    for r in s["rods"]:
        for v in (r["vertices"][0], r["vertices"][-1]):
            ends[v] = ends.get(v, 0) + 1
    free = [v for v, c in ends.items() if c == 1]
    A = held_ids(V, V[:, 0] < x0 + 0.012)
    Bi = held_ids(V, V[:, 0] > x1 - 0.012)
    freeA = [v for v in free if v not in A and v not in Bi]
    poses = [dict(name="gravity", weight=1.0, fixed=fixed_list(A)),
             dict(name="moments", weight=1.0, fixed=fixed_list(A),
                  twisting_moments=[dict(vertex=int(v), moment=1e-4) for v in freeA]),
             dict(name="lift", weight=1.0, fixed=fixed_list(A) + fixed_list(Bi, V[Bi] + [0, 0, 0.02]))]
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 5, tmp, "cylfree",
                            rfun=smooth_r(0.0012, 0.004, V), dfun=smooth_d(0.002, V), grav=[0, 0, -9.81])


def c_sheet_scaled_unloaded(tmp, surf):
    """tri sheet 4x3, K=3 (~50 vertices), two corners held, NO loads;
    pose 1 target: rest shape scaled 1.05 about the centre (in plane); pose 2
    target: rest shape with a 10 mm out-of-plane bump (planar design cannot
    follow); weights 1e6 and 1e-3; rest shape only."""
    s = grid("tri", (0.1, 0.08), (4, 3), 3, tmp)
    V = np.array(s["vertices"])
    c1 = int(np.argmin(V[:, 0] + V[:, 1])); c2 = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="scaled", weight=1e6, fixed=fixed_list([c1, c2])),
             dict(name="bump", weight=1e-3, fixed=fixed_list([c1, c2]))]
    ctr = V.mean(0)
    T1 = ctr + 1.05 * (V - ctr)
    T2 = V.copy(); T2[:, 2] += 0.01 * np.exp(-np.sum((V[:, :2] - ctr[:2]) ** 2, 1) / 0.03 ** 2)
    return finish_geometric(s, poses, dict(scaled=T1, bump=T2), ["rest_shape"], (0.001, 0.005), 4)


CASES2 = [
    ("strip_column_buckle", c_strip_column_buckle, True),
    ("dome_snap", c_dome_snap, True),
    ("tent_nonormals", c_tent_nonormals, True),
    ("stiff_nano", c_stiff_nano, True),
    ("soft_thin_gravity", c_soft_thin_gravity, True),
    ("strip_roll_twist", c_strip_roll_twist, False),
    ("cyl_free_boundary", c_cyl_free_boundary, True),
    ("sheet_scaled_unloaded", c_sheet_scaled_unloaded, False),
]
CASES = CASES + CASES2


# ------------------------------------------------------------------ batch 3
def c_stiff_nano_clamped(tmp, surf):
    """as stiff_nano (E = 1e12 Pa, nanometre displacements) but the left side
    clamped (no hinge mechanism); radii and rest shape; reachable."""
    s = grid("quad", (0.09, 0.09), (3, 3), 4, tmp)
    s["material"] = dict(young_modulus=1e12, poisson_ratio=0.3, density=7800.0)
    V = np.array(s["vertices"])
    L = held_ids(V, V[:, 0] < V[:, 0].min() + 1e-6)
    R = held_ids(V, V[:, 0] > V[:, 0].max() - 1e-6)
    poses = [dict(name="nano", weight=1.0, clamped=[dict(vertex=i) for i in L], forces=[dict(vertex=i, force=[0, 0, -0.01 / len(R)]) for i in R]),
             dict(name="micro", weight=1.0, clamped=[dict(vertex=i) for i in L], forces=[dict(vertex=i, force=[0, 0.05 / len(R), -0.1 / len(R)]) for i in R])]
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "nanoc",
                            rfun=smooth_r(0.0012, 0.004, V), dfun=smooth_d(0.0005, V))


def c_sheet_scaled_only(tmp, surf):
    """sheet_scaled_unloaded's sheet and 'scaled' pose alone (weight 1): the
    target is the rest shape scaled 1.05, exactly reachable by the rest shape
    (linear in arc length, held vertices move with the rest shape)."""
    s = grid("tri", (0.1, 0.08), (4, 3), 3, tmp)
    V = np.array(s["vertices"])
    c1 = int(np.argmin(V[:, 0] + V[:, 1])); c2 = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="scaled", weight=1.0, fixed=fixed_list([c1, c2]))]
    ctr = V.mean(0)
    return finish_geometric(s, poses, dict(scaled=ctr + 1.05 * (V - ctr)), ["rest_shape"], (0.001, 0.005), 4)


def c_strip_planar_compress(tmp, surf):
    """planar quad strip 6 x 1, K=5, left side held, right side prescribed
    3% towards the left; targets IN PLANE: the rest shape compressed
    uniformly in x; radii only (cannot relieve the compression: the in-plane
    optimum is unstable out of plane)."""
    s = grid("quad", (0.24, 0.04), (6, 1), 5, tmp)
    V = np.array(s["vertices"])
    x0, x1 = V[:, 0].min(), V[:, 0].max()
    L = held_ids(V, V[:, 0] < x0 + 1e-6)
    R = held_ids(V, V[:, 0] > x1 - 1e-6)
    w = x1 - x0
    poses = [dict(name="compress", weight=1.0, fixed=fixed_list(L) + fixed_list(R, V[R] - [0.03 * w, 0, 0]))]
    T = V.copy(); T[:, 0] = x0 + (V[:, 0] - x0) * 0.97
    return finish_geometric(s, poses, dict(compress=T), ["radii"], (0.001, 0.005), 4)


def c_big_quad_4poses(tmp, surf):
    """big_quad_both's 7x6 quad sheet (K=5, 347 vertices) with 4 poses:
    0.4 N pull up at the top centre; top side prescribed 6 mm in -y (less
    than the 7.5 mm edge); top side prescribed rotated 30 deg about y around
    its centre; gravity; radii and rest shape; reachable."""
    s = grid("quad", (0.21, 0.18), (7, 6), 5, tmp)
    V = np.array(s["vertices"])
    B = held_ids(V, V[:, 1] < V[:, 1].min() + 1e-6)
    T = held_ids(V, V[:, 1] > V[:, 1].max() - 1e-6)
    top_c = int(np.argmin(np.linalg.norm(V - [0, V[:, 1].max(), 0], axis=1)))
    c = V[T].mean(0)
    poses = [dict(name="pull_up", weight=1.0, fixed=fixed_list(B), forces=[dict(vertex=top_c, force=[0, 0, 0.4])]),
             dict(name="squeeze", weight=1.0, fixed=fixed_list(B) + fixed_list(T, V[T] - [0, 0.006, 0])),
             dict(name="tilt", weight=1.0, fixed=fixed_list(B) + fixed_list(T, rot(V[T], c, [0, 1, 0], math.radians(30)))),
             dict(name="sag", weight=1.0, fixed=fixed_list(B))]
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 4, tmp, "bigquad4",
                            rfun=smooth_r(0.0012, 0.0042, V), dfun=smooth_d(0.003, V, comps=(0, 1)), grav=[0, 0, -9.81])


CASES3 = [
    ("stiff_nano_clamped", c_stiff_nano_clamped, True),
    ("sheet_scaled_only", c_sheet_scaled_only, True),
    ("strip_planar_compress", c_strip_planar_compress, False),
    ("big_quad_4poses", c_big_quad_4poses, True),
]
CASES = CASES + CASES3


# ------------------------------------------------------------------ batch 4
def c_sheet_scaled_equal(tmp, surf):
    """sheet_scaled_unloaded with equal weights (1, 1)."""
    out, hid, info = c_sheet_scaled_unloaded(tmp, surf)
    for p in out["poses"]:
        p["weight"] = 1.0
    return out, hid, info


def c_hex_ties_contacts(tmp, surf):
    """hex sheet 3x3, K=4; left side held; pose 'pull': 0.4 N in +x on the right
    side with an elastic-plastic tie (k 200 N/m, yield 0.05 N) between two
    connections across the sheet; pose 'press': 0.2 N in -x with a soft
    contact (d 20 mm, k 0.5 N) between two connections that approach; radii
    only; reachable (ties/contacts are design independent)."""
    s = grid("hex", (0.12, 0.1), (3, 3), 4, tmp)
    V = np.array(s["vertices"])
    L = held_ids(V, V[:, 0] < V[:, 0].min() + 1e-6)
    R = held_ids(V, V[:, 0] > V[:, 0].max() - 1e-6)
    ends = sorted({r["vertices"][0] for r in s["rods"]} | {r["vertices"][-1] for r in s["rods"]})
    E = np.array(ends)
    a = int(E[np.argmin(np.linalg.norm(V[E] - [-0.03, 0.0, 0], axis=1))])
    b = int(E[np.argmin(np.linalg.norm(V[E] - [0.03, 0.0, 0], axis=1))])
    c = int(E[np.argmin(np.linalg.norm(V[E] - [0.0, 0.03, 0], axis=1))])
    d = int(E[np.argmin(np.linalg.norm(V[E] - [0.0, -0.03, 0], axis=1))])
    poses = [dict(name="pull", weight=1.0, fixed=fixed_list(L), forces=[dict(vertex=i, force=[0.4 / len(R), 0, 0.02 / len(R)]) for i in R],
                  ties=[dict(vertices=[a, b], stiffness=200.0, yield_force=0.05)]),
             dict(name="press", weight=1.0, fixed=fixed_list(L), forces=[dict(vertex=i, force=[-0.2 / len(R), 0, 0.01 / len(R)]) for i in R],
                  contacts=[dict(vertices=[c, d], distance=float(np.linalg.norm(V[c] - V[d])) * 0.95, stiffness=0.5)])]
    return finish_reachable(s, poses, ["radii"], (0.001, 0.005), 4, tmp, "ties",
                            rfun=smooth_r(0.0012, 0.0042, V))


def c_tri_weight0_cp2(tmp, surf):
    """tri sheet 4x4, K=5; bottom held; 3 poses (top lifted 15 mm; top
    pushed 5 mm in +x with weight 0; 0.1 N sideways point force at the top
    corner); control_points_per_rod 2 (linear per rod); radii and rest shape;
    reachable."""
    s = grid("tri", (0.12, 0.1), (4, 4), 5, tmp)
    V = np.array(s["vertices"])
    B = held_ids(V, V[:, 1] < V[:, 1].min() + 1e-6)
    T = held_ids(V, V[:, 1] > V[:, 1].max() - 1e-6)
    corner = int(np.argmax(V[:, 0] + V[:, 1]))
    poses = [dict(name="lift", weight=1.0, fixed=fixed_list(B) + fixed_list(T, V[T] + [0, 0, 0.015])),
             dict(name="push0", weight=0.0, fixed=fixed_list(B) + fixed_list(T, V[T] + [0.005, 0, 0])),
             dict(name="side", weight=1.0, fixed=fixed_list(B), forces=[dict(vertex=corner, force=[0.1, 0, 0.02])])]
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 2, tmp, "cp2",
                            rfun=smooth_r(0.0012, 0.0042, V), dfun=smooth_d(0.003, V))


def c_dome_cp8(tmp, surf):
    """dome ~ 20 cells, rim held, gravity + 0.3 N sideways at the apex;
    control_points_per_rod 8; radii and rest shape; reachable."""
    s = surface(os.path.join(surf, "dome.obj"), 20, tmp, 0.006)
    V = np.array(s["vertices"])
    rim = held_ids(V, V[:, 2] < V[:, 2].min() + 1e-4)
    apex = int(np.argmax(V[:, 2]))
    poses = [dict(name="gravity", weight=1.0, fixed=fixed_list(rim)),
             dict(name="side", weight=1.0, fixed=fixed_list(rim), forces=[dict(vertex=apex, force=[0.3, 0, 0])])]
    return finish_reachable(s, poses, ["radii", "rest_shape"], (0.001, 0.005), 8, tmp, "cp8",
                            rfun=smooth_r(0.0012, 0.0042, V), dfun=smooth_d(0.003, V), grav=[0, 0, -9.81])


def c_cyl_big_unreach(tmp, surf):
    """cylinder patch ~ 60 cells (~ 400 vertices); both long edges (y = +-max)
    held; 3 poses: gravity; 1 N down at the crown; crown prescribed? no:
    the x-ends free; targets: squashed (z 0.85), crown dented, stretched
    along x by 3%; radii and rest shape; unreachable."""
    s = surface(os.path.join(surf, "cyl.obj"), 60, tmp, 0.007)
    V = np.array(s["vertices"])
    H = held_ids(V, V[:, 2] < V[:, 2].min() + 0.004)
    crown = int(np.argmin(np.linalg.norm(V - [0, 0, V[:, 2].max()], axis=1)))
    poses = [dict(name="gravity", weight=1.0, fixed=fixed_list(H)),
             dict(name="press", weight=1.0, fixed=fixed_list(H), forces=[dict(vertex=crown, force=[0, 0, -1.0])]),
             dict(name="stretch", weight=1.0, fixed=fixed_list(H))]
    T1 = V.copy(); T1[:, 2] = V[:, 2].min() + 0.85 * (V[:, 2] - V[:, 2].min())
    T2 = V.copy(); T2[:, 2] -= 0.015 * np.exp(-np.sum((V - V[crown]) ** 2, 1) / 0.03 ** 2)
    T3 = V.copy(); T3[:, 0] *= 1.03
    for T in (T1, T2, T3):
        T[H] = V[H]
    return finish_geometric(s, poses, dict(gravity=T1, press=T2, stretch=T3), ["radii", "rest_shape"], (0.001, 0.005), 4,
                            grav=[0, 0, -9.81])


CASES4 = [
    ("sheet_scaled_equal", c_sheet_scaled_equal, False),
    ("hex_ties_contacts", c_hex_ties_contacts, True),
    ("tri_weight0_cp2", c_tri_weight0_cp2, True),
    ("dome_cp8", c_dome_cp8, True),
    ("cyl_big_unreach", c_cyl_big_unreach, False),
]
CASES = CASES + CASES4


def initial_rms(scene, tmp, tag):
    s = dict(scene); s.pop("design", None)
    q = simulate(s, tmp, tag + "_initial", require=False)
    t, n = 0.0, 0
    for p in scene["poses"]:
        t += float(((q[p["name"]] - np.asarray(p["target"])) ** 2).sum()); n += len(p["target"])
    return math.sqrt(t / n)


def write_cases(cases, out, only, make, unsolved_initial_ok=False):
    """Writes OUT/NAME.json (and NAME.hidden.json) for every (name, fn,
    reachable) of `cases` (or those named in `only`, comma-separated) and
    the index OUT/cases.json that run_sweep.py reads; make(fn, tmp) returns
    (scene, hidden scene or None, info dict). With unsolved_initial_ok, a
    scene whose initial design cannot be simulated is kept (initial RMS
    nan). Returns 1 when a case could not be made, else 0."""
    os.makedirs(out, exist_ok=True)
    idx_path = os.path.join(out, "cases.json")
    index = json.load(open(idx_path)) if os.path.exists(idx_path) else {}
    only = [x for x in only.split(",") if x]
    rc = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name, fn, reach in cases:
            if only and name not in only:
                continue
            try:
                scene, hid, info = make(fn, tmp)
                try:
                    r0 = initial_rms(scene, tmp, name)
                except Failure as e:
                    if not unsolved_initial_ok:
                        raise
                    print("%s: initial simulate failed: %s" % (name, str(e)[-300:]), file=sys.stderr)
                    r0 = float("nan")
            except Failure as e:
                print("%s: FAILED: %s" % (name, str(e)[-1500:]), file=sys.stderr)
                rc = 1
                continue
            json.dump(scene, open(os.path.join(out, name + ".json"), "w"))
            if hid is not None:
                json.dump(hid, open(os.path.join(out, name + ".hidden.json"), "w"))
            index[name] = dict(vertices=len(scene["vertices"]), rods=len(scene["rods"]),
                               poses=[p["name"] for p in scene["poses"]], parameters=scene["design"]["parameters"],
                               reachable=reach, initial_rms_mm=round(1e3 * r0, 4),
                               description=" ".join(fn.__doc__.split()), **info)
            print("%s: %d vertices, %d rods, %d poses, %s, reachable=%s, initial RMS %.3f mm" % (
                name, len(scene["vertices"]), len(scene["rods"]), len(scene["poses"]),
                "+".join(scene["design"]["parameters"]), reach, 1e3 * r0), flush=True)
            json.dump(index, open(idx_path, "w"), indent=1)
    return rc


def main():
    global RODMESH
    ap = argparse.ArgumentParser()
    ap.add_argument("--rodmesh", default=RODMESH)
    ap.add_argument("--out", required=True)
    ap.add_argument("--only", default="")
    a = ap.parse_args()
    RODMESH = os.path.abspath(a.rodmesh)
    os.makedirs(a.out, exist_ok=True)
    surf = os.path.join(a.out, "surfaces")
    os.makedirs(surf, exist_ok=True)
    dome_obj(os.path.join(surf, "dome.obj"))
    cylinder_obj(os.path.join(surf, "cyl.obj"))
    saddle_obj(os.path.join(surf, "saddle.obj"))
    return write_cases(CASES, a.out, a.only, lambda fn, tmp: fn(tmp, surf))


if __name__ == "__main__":
    sys.exit(main())
