#!/usr/bin/python3
"""Writes the example input surfaces of `rodmesh mesh` (metres, OBJ).

    /usr/bin/python3 examples/make_surfaces.py [OUTDIR]   # default examples/surfaces

Four surfaces, each with two deformed copies with the same connectivity (the
target poses): a hat-like dome with a brim (open, ~0.23 m long, like the
paper's hat), a sphere (closed), a flat square sheet (open, 0.2 m, like the
paper's sheet) and an elongated toy-like body (closed, ~0.21 m, like the
paper's dinosaur). Deterministic, numpy only, no downloads. The meshes are
deliberately coarse (a few hundred vertices): `rodmesh mesh` refines them
internally, and the committed files stay small.
"""
import os
import sys

import numpy as np


def write_obj(path, V, F, comment):
    with open(path, "w") as f:
        f.write("# %s\n# %d vertices, %d faces, metres\n" % (comment, len(V), len(F)))
        for v in V:
            f.write("v %.6g %.6g %.6g\n" % (v[0], v[1], v[2]))
        for t in F:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))


def revolve(profile, n_theta, sx=1.0, sy=1.0):
    """Surface of revolution around z of a profile [(rho, z)] starting at the
    pole (rho = 0). Returns vertices and outward-consistent triangles."""
    V = [[0.0, 0.0, profile[0][1]]]
    th = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    for rho, z in profile[1:]:
        for t in th:
            V.append([sx * rho * np.cos(t), sy * rho * np.sin(t), z])
    F = []
    for j in range(n_theta):  # pole fan
        F.append((0, 1 + j, 1 + (j + 1) % n_theta))
    for i in range(len(profile) - 2):
        a, b = 1 + i * n_theta, 1 + (i + 1) * n_theta
        for j in range(n_theta):
            j1 = (j + 1) % n_theta
            F.append((a + j, b + j, b + j1))
            F.append((a + j, b + j1, a + j1))
    return np.array(V), np.array(F)


def hat():
    # Crown: quarter ellipse (radius 0.075, height 0.085); brim: 0.025 wide,
    # slightly drooping. Stretched to ~0.23 m along x.
    prof = []
    for a in np.linspace(0, np.pi / 2, 13):
        prof.append((0.075 * np.sin(a), 0.085 * np.cos(a)))
    for s in np.linspace(0, 1, 5)[1:]:
        prof.append((0.075 + 0.025 * s, -0.006 * s * s))
    V, F = revolve(prof, 48, sx=1.15, sy=1.0)
    x, y, z = V[:, 0], V[:, 1], V[:, 2]
    # Pose 1: the front (x > 0) folds down, more towards the front edge.
    P1 = V.copy()
    w = np.clip(x / 0.115, 0, None) ** 2
    P1[:, 2] -= 0.045 * w
    P1[:, 0] -= 0.01 * w
    # Pose 2: the crown leans to +y and the left side (y > 0) sags.
    P2 = V.copy()
    P2[:, 1] += 0.03 * np.clip(z / 0.085, 0, 1) ** 1.5
    P2[:, 2] -= 0.02 * np.clip(y / 0.1, 0, None) ** 2
    return V, F, [("front_down", P1), ("lean_left", P2)]


def sphere():
    # Icosphere, 3 subdivisions (642 vertices), radius 0.08.
    t = (1 + 5 ** 0.5) / 2
    V = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    F = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    V = [np.array(v, float) / np.linalg.norm(v) for v in V]
    for _ in range(3):
        mid = {}

        def m(a, b):
            k = (min(a, b), max(a, b))
            if k not in mid:
                p = V[a] + V[b]
                V.append(p / np.linalg.norm(p))
                mid[k] = len(V) - 1
            return mid[k]

        G = []
        for a, b, c in F:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            G += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        F = G
    V = 0.08 * np.array(V)
    F = np.array(F)
    # Pose 1: squashed (fixed at the bottom, pressed from the top).
    P1 = V.copy()
    P1[:, 2] = np.where(V[:, 2] > -0.08, -0.08 + 0.75 * (V[:, 2] + 0.08), V[:, 2])
    P1[:, 0] *= 1.0 + 0.12 * (1 - (V[:, 2] / 0.08) ** 2)
    P1[:, 1] *= 1.0 + 0.12 * (1 - (V[:, 2] / 0.08) ** 2)
    # Pose 2: top sheared sideways.
    P2 = V.copy()
    P2[:, 0] += 0.03 * ((V[:, 2] + 0.08) / 0.16) ** 2
    return V, F, [("squash", P1), ("shear", P2)]


def sheet():
    # 0.2 m square in z = 0, 20 x 20 quads split alternately.
    n = 21
    xs = np.linspace(-0.1, 0.1, n)
    V = np.array([[x, y, 0.0] for y in xs for x in xs])
    F = []
    for j in range(n - 1):
        for i in range(n - 1):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i
            if (i + j) % 2 == 0:
                F += [(a, b, c), (a, c, d)]
            else:
                F += [(a, b, d), (b, c, d)]
    x, y = V[:, 0], V[:, 1]
    # Pose 1: bent into a trough along x (edges x = +-0.1 lifted).
    P1 = V.copy()
    P1[:, 2] = 2.0 * x ** 2
    P1[:, 0] = x * (1 - 0.6 * x ** 2 / 0.01 * 0.1)
    # Pose 2: twisted (saddle).
    P2 = V.copy()
    P2[:, 2] = 3.0 * x * y
    return V, np.array(F), [("trough", P1), ("twist", P2)]


def toy():
    # Elongated body of revolution around x (0.21 m), with a neck and a head
    # bulge at +x and a tapering tail at -x, slightly flattened in y.
    n_u, n_v = 30, 24
    prof = []
    for i in range(n_u + 1):
        u = i / n_u  # 0 at the tail tip, 1 at the nose
        x = -0.105 + 0.21 * u
        r = 0.045 * np.sin(np.pi * u) ** 0.8
        r *= 1 - 0.35 * np.exp(-((u - 0.78) / 0.06) ** 2)  # neck
        r *= 1 + 0.25 * np.exp(-((u - 0.9) / 0.05) ** 2)   # head
        prof.append((x, r))
    V = [[prof[0][0], 0.0, 0.0]]
    th = np.linspace(0, 2 * np.pi, n_v, endpoint=False)
    for x, r in prof[1:-1]:
        for t in th:
            V.append([x, 0.85 * r * np.cos(t), r * np.sin(t)])
    V.append([prof[-1][0], 0.0, 0.0])
    V = np.array(V)
    F = []
    last = len(V) - 1
    for j in range(n_v):
        F.append((0, 1 + (j + 1) % n_v, 1 + j))
    for i in range(n_u - 2):
        a, b = 1 + i * n_v, 1 + (i + 1) * n_v
        for j in range(n_v):
            j1 = (j + 1) % n_v
            F += [(a + j, b + j1, b + j), (a + j, a + j1, b + j1)]
    a = 1 + (n_u - 2) * n_v
    for j in range(n_v):
        F.append((a + j, a + (j + 1) % n_v, last))
    x = V[:, 0]
    # Pose 1: the tail (x < -0.03) curls up.
    P1 = V.copy()
    s = np.clip((-0.03 - x) / 0.075, 0, None)
    P1[:, 2] += 0.05 * s ** 2
    P1[:, 0] += 0.01 * s ** 2
    # Pose 2: the head (x > 0.05) turns to +y about the neck.
    P2 = V.copy()
    ang = 0.5 * np.clip((x - 0.05) / 0.055, 0, 1)
    c, sn = np.cos(ang), np.sin(ang)
    dx, dy = x - 0.05, V[:, 1]
    P2[:, 0] = 0.05 + c * dx - sn * dy
    P2[:, 1] = sn * dx + c * dy
    return V, np.array(F), [("tail_up", P1), ("head_turn", P2)]


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "surfaces")
    os.makedirs(out, exist_ok=True)
    for name, make in [("hat", hat), ("sphere", sphere), ("sheet", sheet), ("toy", toy)]:
        V, F, poses = make()
        write_obj(os.path.join(out, name + ".obj"), V, F, name + " (rest)")
        for pname, P in poses:
            write_obj(os.path.join(out, "%s_%s.obj" % (name, pname)), P, F,
                      "%s deformed copy '%s' (same connectivity as %s.obj)" % (name, pname, name))
        print("%s: %d vertices, %d faces, poses %s" % (name, len(V), len(F), ", ".join(p for p, _ in poses)))


if __name__ == "__main__":
    main()
