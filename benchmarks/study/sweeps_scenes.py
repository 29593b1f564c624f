"""Scenes, runs and archives for benchmarks/study/sweeps.py.

Sheets come from `rodmesh mesh --grid hex`; their targets are the equilibria
of a *hidden design* that is a smooth function of position (radii and a
vertical rest displacement), so the same hidden design exists at every
discretization. Designs are moved between discretizations through their
control points (contract §4: per rod, Bernstein control values at arc
fractions j/(n-1), shared ends), which do not depend on the vertices per rod.
"""
import json
import math
import re
import resource
import subprocess
import time

import h5py
import numpy as np


class RunError(RuntimeError):
    pass


def run(cmd, ok=(0,), timeout=None):
    """Runs a command; returns (exit status, wall seconds, stderr)."""
    t0 = time.perf_counter()
    p = subprocess.run([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                       timeout=timeout)
    wall = time.perf_counter() - t0
    if p.returncode not in ok:
        raise RunError("%s exited %d:\n%s" % (" ".join(map(str, cmd)), p.returncode, p.stderr[-3000:]))
    return p.returncode, wall, p.stderr


def hex_sheet(rodmesh, path, cells, k, size=None, pulls=(), extra=()):
    """A hex sheet (`rodmesh mesh --grid hex`, 25 mm rods unless `size` is given)
    held on its left side, with gravity and one pose per pull (fx, fy, fz) on
    its right side; returns the scene dict."""
    nx, ny = cells
    if size is None:
        size = (0.025 * math.sqrt(3) * nx, 0.0375 * ny + 0.0125)  # 25 mm rods, regular cells
    cmd = [rodmesh, "mesh", "--grid", "hex", "--size", size[0], size[1], "--cells", nx, ny, "--rod-vertices", k,
           "--fix-side", "left", "--gravity", 0, 0, -9.81, "-o", path, "-q"]
    for f in pulls:
        cmd += ["--pull", "right", f[0], f[1], f[2]]
    run(cmd + list(extra))
    return json.load(open(path))


POSE_LOADS = [(0.15, 0.0, 0.0), (0.0, 0.0, 0.02), (0.1, 0.1, 0.0), (0.0, 0.0, -0.02), (0.1, -0.1, 0.0),
              (0.05, 0.0, 0.03), (0.0, 0.12, 0.0), (0.08, 0.0, -0.03)]


def hidden_design(vertices):
    """Per-vertex radii [r_t, r_n] (m) and rest displacement (m) of the hidden
    design: smooth functions of the rest position, inside [1, 5] mm."""
    V = np.asarray(vertices, float)
    lo, hi = V.min(0), V.max(0)
    span = np.maximum(hi - lo, 1e-12)
    xi, eta = (V[:, 0] - lo[0]) / span[0], (V[:, 1] - lo[1]) / span[1]
    rt = 1.6e-3 + 1.2e-3 * (0.5 + 0.5 * np.sin(2.2 * xi + 1.0) * np.cos(1.5 * eta))
    rn = 1.4e-3 + 1.4e-3 * (0.3 + 0.7 * xi * (1 - 0.4 * eta))
    disp = np.zeros_like(V)
    disp[:, 2] = 1.5e-3 * np.sin(math.pi * xi) * np.sin(math.pi * eta)
    return np.stack([rt, rn], 1), disp


def simulate(rodmesh, scene, path, extra=()):
    json.dump(scene, open(path, "w"))
    out = path + ".h5"
    run([rodmesh, "simulate", path, "-o", out, "-q"] + list(extra))
    with h5py.File(out) as f:
        return {n: f["poses/%s/positions" % n][()] for n in f["poses"]}


def with_targets(rodmesh, scene, path, radius=(0.002, 0.002)):
    """The scene with every pose's target the equilibrium of the hidden design,
    uniform initial radii and the design block (radii and rest shape free)."""
    r, d = hidden_design(scene["vertices"])
    hid = dict(scene)
    hid["vertices"] = (np.asarray(scene["vertices"]) + d).tolist()
    hid["radii"] = r.tolist()
    hid.pop("design", None)
    pos = simulate(rodmesh, hid, path + ".hidden.json")
    out = dict(scene)
    out["radius"] = list(radius)
    out.pop("radii", None)
    out["poses"] = [dict(p, target=pos[p["name"]].tolist()) for p in scene["poses"]]
    out["design"] = dict(parameters=["radii", "rest_shape"], radius_bounds=[0.001, 0.005], control_points_per_rod=4)
    json.dump(out, open(path, "w"))
    return out


def read_optimize(path):
    """What the sweeps need from an optimize archive."""
    with h5py.File(path) as f:
        a = dict(f.attrs)
        h = f["history"]
        poses = list(f["poses"])
        return dict(
            status=str(a["status"]), method=str(a["method"]), iterations=int(a["iterations"]),
            time_s=float(a["time_s"]), evaluation_s=float(a.get("evaluation_time_s", float("nan"))),
            peak_mib=float(a.get("peak_memory_bytes", 0)) / 2**20, message=str(a.get("message", "")),
            design_derivatives=str(a.get("design_derivatives", "")),
            hist_t=h["time_s"][()], hist_rms=h["rms_error"][()], hist_it=h["iteration"][()],
            hist_phase=h["phase"].asstr()[()] if "phase" in h else None, hist_level=h["level"][()],
            last_violation=float(h["constraint_violation"][-1]), rms=rms_of(f), residual=max(float(f["poses"][p].attrs["residual_norm"]) for p in poses),
            gap=max(float(f["poses"][p].attrs.get("equilibrium_gap", 0.0)) for p in poses),
            dofs=int(f["model"].attrs["dofs_per_pose"]), n_vertices=int(f["model"].attrs["n_vertices"]))


def rms_of(f):
    s, n = 0.0, 0
    for p in f["poses"]:
        q, t = f["poses/%s/positions" % p][()], f["poses/%s/target" % p][()]
        s += float(((q - t) ** 2).sum())
        n += q.shape[0]
    return math.sqrt(s / n)


def optimize(rodmesh, scene_path, out, args, timeout=None):
    """Runs `rodmesh optimize`; returns read_optimize() plus the process's wall and CPU time."""
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    rc, wall, err = run([rodmesh, "optimize", scene_path, "-o", out, "-q"] + list(args), ok=(0, 1), timeout=timeout)
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = read_optimize(out)
    r["exit"], r["wall_s"] = rc, wall
    # CPU time (user + system) of the process: on a shared machine, wall time includes waiting for a core.
    r["cpu_s"] = (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)
    return r


# --- design transfer between discretizations ---------------------------------

def rod_arc_fractions(vertices, rod):
    P = np.asarray([vertices[v] for v in rod["vertices"]], float)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    return s / s[-1]


def bernstein(n, s):
    """Bernstein basis of degree n - 1 at s (len(s) x n)."""
    s = np.asarray(s, float)[:, None]
    j = np.arange(n)[None, :]
    c = np.array([math.comb(n - 1, i) for i in range(n)])[None, :]
    return c * s ** j * (1 - s) ** (n - 1 - j)


def control_polygon(path):
    """Per rod, its control values in order along the rod: (C_r x 2 radii, C_r x 3 displacements)."""
    with h5py.File(path) as f:
        cp = f["design/control_points"]
        R, D = cp["radii"][()], cp["rest_displacement"][()]
        rod, arc, vert = cp["rod"][()], cp["arc_fraction"][()], cp["vertex"][()]
        scene = json.loads(f["scene"].asstr()[()] if f["scene"].shape == () else f["scene"][0])
    end = {int(v): i for i, (r, v) in enumerate(zip(rod, vert)) if r < 0}
    polys = []
    for ri, r in enumerate(scene["rods"]):
        inner = sorted([i for i in range(len(rod)) if rod[i] == ri], key=lambda i: arc[i])
        idx = [end[r["vertices"][0]]] + inner + [end[r["vertices"][-1]]]
        polys.append((R[idx], D[idx]))
    return scene, polys


def apply_design(polys, scene):
    """Per-vertex radii and rest positions of `scene` (same rods, any vertices
    per rod) under the control polygons."""
    V = np.asarray(scene["vertices"], float)
    radii = np.zeros((len(V), 2))
    rest = V.copy()
    for (R, D), rod in zip(polys, scene["rods"]):
        B = bernstein(len(R), rod_arc_fractions(V, rod))
        idx = rod["vertices"]
        radii[idx] = B @ R
        rest[idx] = V[idx] + B @ D
    return radii, rest


def same_rods(a, b, tol=1e-9):
    """Whether two sheets have the same rods (same end vertices and positions)."""
    if len(a["rods"]) != len(b["rods"]):
        return False
    for ra, rb in zip(a["rods"], b["rods"]):
        for ea, eb in ((ra["vertices"][0], rb["vertices"][0]), (ra["vertices"][-1], rb["vertices"][-1])):
            if np.linalg.norm(np.subtract(a["vertices"][ea], b["vertices"][eb])) > tol:
                return False
    return True


def steps_of_dynamic_run(stderr):
    """Accepted and rejected time steps per pose from `simulate --dynamic`'s report."""
    m = re.findall(r"in (\d+) steps \((\d+) rejected", stderr)
    if not m:
        raise RunError("simulate --dynamic: no step count in its report:\n" + stderr[-2000:])
    return [(int(a), int(b)) for a, b in m]
