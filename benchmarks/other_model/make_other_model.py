#!/usr/bin/python3
"""Design scenes whose targets no rod mesh reaches (issue 20, item 4).

    /usr/bin/python3 benchmarks/other_model/make_other_model.py --rodmesh BIN --out DIR [--only a,b]

writes DIR/CASE.json (rodmesh-scene/1 with a `design` block: radii and rest
shape free) and DIR/cases.json (vertices, poses, the initial design's RMS per
pose). Every case is a hex sheet (`rodmesh mesh --grid hex`) held along its
left side (the vertical boundary rods) whose right side (the vertical rods
there, "the handle") is moved in each pose; the targets come from another
model of the same sheet:

  shell_small   targets from a dense triangle-mesh shell (below) of the
                sheet's bounding rectangle, the half towards the handle's
                upper corner ten times softer than the other; gravity in
                both models; poses: handle lifted; twisted; lifted, twisted
                and pushed towards the held side (98 vertices)
  shape_small   purely geometric targets: the sheet rolled onto a cylinder
                from the held side on; twisted into a helicoid; a bulge
                (non-developable, so that no rod mesh that keeps its rod
                lengths reaches it); no gravity (98 vertices)
  mixed_small   radii free only: shell_small's lift and twist (the rod
                scene without gravity) and shape_small's bulge, a pose
                without any load
  shell_large   shell_small's model on a 4 x 5 cell sheet with 11 vertices
                per rod (the paper sheet's size) for a benchmark row

The shell is a mass-spring model, a physics rod meshes do not have:
  - stretching: a spring on every triangle edge, energy k/2 (l - l0)^2 with
    k = Y A_e / l0^2 (A_e a third of the adjacent triangles' area), so that a
    uniform strain e stores about Y/2 e^2 per unit area;
  - bending: per interior edge (hinge) with opposite vertices a, b the
    affine-invariant 4-point stencil K (weights w with sum w = 0 and
    sum w p = 0 over the flat rest positions p; normalised so that a fold of
    the hinge by a small angle t gives |K x| = t), energy D/2 * 3 |e|^2 / A_h
    * |K x|^2 (A_h the two triangles' area): quadratic in the positions,
    invariant under rigid motions, zero for every in-plane affine map;
  - gravity: the rod mesh's own mass, spread over the shell by area.
Equilibria by Newton on the free nodes with the stretch Hessian projected
to positive semi-definite, an energy line search, and continuation in the
handle motion and gravity (20 steps); each step must converge to a residual
of 1e-7 of the largest nodal force (a position error of nanometres) or the
script stops (exit 1).

Targets of the rod vertices: barycentric interpolation of the shell's
deformed positions over the rest triangle holding the vertex (held and
handle vertices: their prescribed positions, which the shell's held nodes
follow exactly).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

HERE = os.path.dirname(os.path.abspath(__file__))

N_CONTROL = 4
RADIUS = 0.002
BOUNDS = (0.001, 0.005)
GRAVITY = 9.81


class Failure(RuntimeError):
    pass


# --------------------------------------------------------------------------
# The rod sheet and its poses

def hex_sheet(rodmesh, tmp, cells, k, gravity):
    path = os.path.join(tmp, "sheet_%dx%d_%d.json" % (cells[0], cells[1], k))
    size = (0.025 * math.sqrt(3) * cells[0], 0.0375 * cells[1] + 0.0125)  # 25 mm rods
    cmd = [rodmesh, "mesh", "--grid", "hex", "--size", size[0], size[1], "--cells", cells[0], cells[1],
           "--rod-vertices", k, "--fix-side", "left", "-o", path, "-q"]
    if gravity:
        cmd += ["--gravity", 0, 0, -GRAVITY]
    r = subprocess.run([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise Failure("rodmesh mesh failed:\n" + r.stderr)
    with open(path) as f:
        return json.load(f)


def sides(V):
    """Held (left) and handle (right) vertices: on the vertical boundary rods."""
    tol = 1e-6
    xmin, xmax = V[:, 0].min(), V[:, 0].max()
    held = np.where(V[:, 0] < xmin + tol)[0]
    handle = np.where(V[:, 0] > xmax - tol)[0]
    return held, handle


def rotation_x(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rigid_handle(lift=0.0, twist=0.0, push=0.0):
    """A rigid motion of the handle (a function of its rest positions and the
    fraction t of the motion): rotation by t*twist about the handle's own
    x-parallel centre line, then translation by t*(-push, 0, lift)."""
    def move(P, centre, t):
        R = rotation_x(t * twist)
        return (P - centre) @ R.T + centre + t * np.array([-push, 0.0, lift])
    return move


# --------------------------------------------------------------------------
# The triangle-mesh shell

class Shell:
    def __init__(self, lo, hi, h, young, bending, soft, total_mass, gravity):
        """Triangulated rectangle [lo, hi] (x, y) with spacing about h; stiff
        constants young (N/m) and bending (N m); soft(x, y) -> True where
        they are ten times smaller."""
        nx = max(2, int(round((hi[0] - lo[0]) / h)))
        ny = max(2, int(round((hi[1] - lo[1]) / h)))
        xs, ys = np.linspace(lo[0], hi[0], nx + 1), np.linspace(lo[1], hi[1], ny + 1)
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        self.P = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], 1)
        idx = np.arange(X.size).reshape(nx + 1, ny + 1)
        tris = []
        for i in range(nx):
            for j in range(ny):
                a, b, c, d = idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]
                if (i + j) % 2 == 0:  # alternating diagonals: no preferred shear direction
                    tris += [(a, b, c), (a, c, d)]
                else:
                    tris += [(a, b, d), (b, c, d)]
        self.T = np.array(tris)
        self.n = len(self.P)
        P2 = self.P[:, :2]
        e1, e2 = P2[self.T[:, 1]] - P2[self.T[:, 0]], P2[self.T[:, 2]] - P2[self.T[:, 0]]
        self.area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        cen = P2[self.T].mean(1)
        factor = np.where([soft(x, y) for x, y in cen], 0.1, 1.0)
        # Edges with their adjacent triangles.
        edges = {}
        for t, tri in enumerate(self.T):
            for k in range(3):
                i, j = sorted((tri[k], tri[(k + 1) % 3]))
                edges.setdefault((i, j), []).append((t, tri[(k + 2) % 3]))
        E, kE, hinges = [], [], []
        for (i, j), adj in edges.items():
            l0 = np.linalg.norm(P2[i] - P2[j])
            a_e = sum(self.area[t] for t, _ in adj) / 3.0
            f = np.mean([factor[t] for t, _ in adj])
            E.append((i, j))
            kE.append(young * f * a_e / l0 ** 2)
            if len(adj) == 2:
                hinges.append((i, j, adj[0][1], adj[1][1], f, sum(self.area[t] for t, _ in adj)))
        self.E = np.array(E)
        self.kE = np.array(kE)
        self.l0 = np.linalg.norm(P2[self.E[:, 0]] - P2[self.E[:, 1]], axis=1)
        # Bending: B = sum_h c_h w w^T (per coordinate).
        rows, cols, vals = [], [], []
        for i, j, a, b, f, A in hinges:
            ids = [a, b, i, j]
            M = np.vstack([P2[ids].T, np.ones(4)])
            w = np.linalg.svd(M)[2][-1]
            e = P2[j] - P2[i]
            le = np.linalg.norm(e)
            ha = abs(e[0] * (P2[a] - P2[i])[1] - e[1] * (P2[a] - P2[i])[0]) / le
            w = w / (w[0] * ha)
            c = bending * f * 3.0 * le ** 2 / A
            for p in range(4):
                for q in range(4):
                    rows.append(ids[p])
                    cols.append(ids[q])
                    vals.append(c * w[p] * w[q])
        B = sp.coo_matrix((vals, (rows, cols)), shape=(self.n, self.n)).tocsr()
        self.B3 = sp.kron(B, sp.identity(3), format="csr")
        # Lumped mass by area.
        m = np.zeros(self.n)
        for t, tri in enumerate(self.T):
            m[tri] += self.area[t] / 3.0
        m *= total_mass / m.sum()
        self.fg = np.zeros((self.n, 3))
        self.fg[:, 2] = -gravity * m

    def energy(self, x, g_scale):
        X = x.reshape(-1, 3)
        d = X[self.E[:, 0]] - X[self.E[:, 1]]
        l = np.linalg.norm(d, axis=1)
        es = 0.5 * np.sum(self.kE * (l - self.l0) ** 2)
        eb = 0.5 * x @ (self.B3 @ x)
        return es + eb - g_scale * np.sum(self.fg.ravel() * x)

    def gradient_hessian(self, x, g_scale, hessian=True):
        X = x.reshape(-1, 3)
        d = X[self.E[:, 0]] - X[self.E[:, 1]]
        l = np.linalg.norm(d, axis=1)
        u = d / l[:, None]
        fs = (self.kE * (l - self.l0))[:, None] * u
        g = np.zeros((self.n, 3))
        np.add.at(g, self.E[:, 0], fs)
        np.add.at(g, self.E[:, 1], -fs)
        g = g.ravel() + self.B3 @ x - g_scale * self.fg.ravel()
        if not hessian:
            return g, None
        # Spring Hessian k [(1 - l0/l) (I - u u^T) + u u^T], the first term
        # clamped at zero (compressed springs) so that Newton's matrix is PSD.
        a = np.maximum(0.0, 1.0 - self.l0 / l)
        K = self.kE[:, None, None] * (a[:, None, None] * (np.eye(3)[None] - u[:, :, None] * u[:, None, :]) +
                                      u[:, :, None] * u[:, None, :])
        i3 = 3 * self.E[:, 0][:, None] + np.arange(3)[None]
        j3 = 3 * self.E[:, 1][:, None] + np.arange(3)[None]
        rows, cols, vals = [], [], []
        for (r, c, s) in ((i3, i3, 1), (j3, j3, 1), (i3, j3, -1), (j3, i3, -1)):
            rows.append(np.repeat(r, 3, axis=1).ravel())
            cols.append(np.tile(c, (1, 3)).ravel())
            vals.append(s * K.reshape(len(K), 9).ravel())
        H = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(3 * self.n, 3 * self.n)).tocsr()
        return g, H + self.B3

    def solve(self, held, positions_of_held, steps=20, tag=""):
        """Equilibrium with nodes `held` at positions_of_held(t) for t = 1/steps
        ... 1 (gravity ramped alike); returns the positions (n x 3)."""
        x = self.P.ravel().copy()
        free = np.ones(3 * self.n, bool)
        for v in held:
            free[3 * v:3 * v + 3] = False
        fidx = np.where(free)[0]
        for s in range(1, steps + 1):
            t = s / steps
            X = x.reshape(-1, 3)
            X[held] = positions_of_held(t)
            x = X.ravel()
            scale = None
            for it in range(200):
                g, H = self.gradient_hessian(x, t)
                gf = g[fidx]
                if scale is None:
                    scale = max(np.abs(self.fg).max(), np.abs(gf).max(), 1e-12)
                if np.abs(gf).max() < 1e-7 * scale:
                    break
                Hff = H[fidx][:, fidx] + 1e-12 * scale * sp.identity(len(fidx))
                dx = spla.spsolve(Hff.tocsc(), -gf, permc_spec="MMD_AT_PLUS_A")
                e0 = self.energy(x, t)
                alpha = 1.0
                while alpha > 1e-10:
                    xn = x.copy()
                    xn[fidx] += alpha * dx
                    if self.energy(xn, t) <= e0 + 1e-4 * alpha * gf @ dx:
                        break
                    alpha *= 0.5
                else:
                    # Near the solution the energy's round-off hides the
                    # decrease: take the Newton step if it lowers the residual.
                    xn = x.copy()
                    xn[fidx] += dx
                    if np.abs(self.gradient_hessian(xn, t, False)[0][fidx]).max() >= np.abs(gf).max():
                        raise Failure("shell %s: line search failed at step %d/%d (residual %.3g of %.3g)"
                                      % (tag, s, steps, np.abs(gf).max(), scale))
                x = xn
            else:
                raise Failure("shell %s: no equilibrium at step %d/%d (residual %.3g of %.3g)"
                              % (tag, s, steps, np.abs(gf).max(), scale))
        return x.reshape(-1, 3)

    def interpolate(self, Xdef, pts):
        """Deformed positions of rest points pts (m x 2) by barycentric
        interpolation over the rest triangle holding each point."""
        P2 = self.P[:, :2]
        out = np.zeros((len(pts), 3))
        A = P2[self.T[:, 0]]
        e1, e2 = P2[self.T[:, 1]] - A, P2[self.T[:, 2]] - A
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        for k, p in enumerate(pts):
            r = p - A
            b1 = (r[:, 0] * e2[:, 1] - r[:, 1] * e2[:, 0]) / det
            b2 = (e1[:, 0] * r[:, 1] - e1[:, 1] * r[:, 0]) / det
            b0 = 1 - b1 - b2
            worst = np.minimum(np.minimum(b0, b1), b2)
            t = int(np.argmax(worst))
            if worst[t] < -1e-9:
                raise Failure("rod vertex %s lies outside the shell" % (p,))
            tri = self.T[t]
            out[k] = b0[t] * Xdef[tri[0]] + b1[t] * Xdef[tri[1]] + b2[t] * Xdef[tri[2]]
        return out


def rod_mass(scene):
    V = np.asarray(scene["vertices"], float)
    length = 0.0
    for rod in scene["rods"]:
        P = V[rod["vertices"]]
        length += np.linalg.norm(np.diff(P, axis=0), axis=1).sum()
    r = scene.get("radius", [RADIUS, RADIUS])
    return scene["material"]["density"] * math.pi * r[0] * r[1] * length


# --------------------------------------------------------------------------
# Cases

def finish(scene, poses, bounds=BOUNDS):
    """The scene with `poses` [(name, fixed list, target array)] and the design
    block (bounds None: the default radius range)."""
    out = dict(scene)
    out.pop("radii", None)
    out["radius"] = [RADIUS, RADIUS]
    out["poses"] = [dict(name=n, weight=1.0, fixed=fixed, target=np.asarray(t).tolist()) for n, fixed, t in poses]
    out["design"] = dict(parameters=["radii", "rest_shape"], control_points_per_rod=N_CONTROL)
    if bounds is not None:
        out["design"]["radius_bounds"] = list(bounds)
    return out


def shell_case(rodmesh, tmp, cells, k, motions, shell_h, soft="corner", bounds=BOUNDS):
    scene = hex_sheet(rodmesh, tmp, cells, k, gravity=True)
    V = np.asarray(scene["vertices"], float)
    held, handle = sides(V)
    lo, hi = V[:, :2].min(0), V[:, :2].max(0)
    yc = 0.5 * (lo[1] + hi[1])
    # Stiff half: about the bending stiffness of the 2 mm rod sheet per unit
    # width (E pi r^4 / 4 over a 43 mm cell); a membrane whose bending length
    # sqrt(D / Y) is 3 mm. The half beyond the diagonal from the held side's
    # top to the handle's bottom (the handle's upper corner) ten times softer
    # in both, so that no pose is symmetric.
    E = scene["material"]["young_modulus"]
    D = E * math.pi * RADIUS ** 4 / 4 / (0.025 * math.sqrt(3))
    Y = D / 0.003 ** 2
    xc, W, H = 0.5 * (lo[0] + hi[0]), hi[0] - lo[0], hi[1] - lo[1]
    softs = {"corner": lambda x, y: (x - xc) / W + (y - yc) / H > 0,  # the handle's upper corner
             "held": lambda x, y: x < xc,  # the half along the held side
             "none": lambda x, y: False}
    shell = Shell(lo, hi, shell_h, Y, D, softs[soft], rod_mass(scene), GRAVITY)
    sh_held = np.where(shell.P[:, 0] <= lo[0] + 1.01 * shell_h)[0]
    sh_handle = np.where(shell.P[:, 0] >= hi[0] - 1.01 * shell_h)[0]
    sh_all = np.concatenate([sh_held, sh_handle])
    centre = np.array([hi[0], yc, 0.0])
    poses = []
    for name, move in motions:
        def held_at(t, move=move):
            return np.vstack([shell.P[sh_held], move(shell.P[sh_handle], centre, t)])
        X = shell.solve(sh_all, held_at, tag=name)
        T = shell.interpolate(X, V[:, :2])
        T[held] = V[held]
        T[handle] = move(V[handle], centre, 1.0)
        fixed = [dict(vertex=int(v)) for v in held] + [dict(vertex=int(v), position=T[v].tolist()) for v in handle]
        poses.append((name, fixed, T))
    return finish(scene, poses, bounds)


def shape_case(rodmesh, tmp, cells, k):
    scene = hex_sheet(rodmesh, tmp, cells, k, gravity=False)
    scene.pop("gravity", None)
    V = np.asarray(scene["vertices"], float)
    held, handle = sides(V)
    lo, hi = V.min(0), V.max(0)
    W, H = hi[0] - lo[0], hi[1] - lo[1]
    yc = 0.5 * (lo[1] + hi[1])
    s = V[:, 0] - lo[0]

    def roll(angle):  # onto a cylinder of axis y, the held side tangent to it
        R = W / angle
        T = V.copy()
        T[:, 0] = lo[0] + R * np.sin(s / R)
        T[:, 2] = R * (1 - np.cos(s / R))
        return T

    def helicoid(angle):  # cross-sections x = const turned about the centre line
        phi = angle * s / W
        T = V.copy()
        T[:, 1] = yc + (V[:, 1] - yc) * np.cos(phi)
        T[:, 2] = (V[:, 1] - yc) * np.sin(phi)
        return T

    def bulge(height):  # a dome over the free part, both sides flat
        T = V.copy()
        eta = (V[:, 1] - yc) / (0.5 * H)
        T[:, 2] = height * np.sin(math.pi * s / W) ** 2 * (1 - 0.5 * eta ** 2)
        return T

    poses = []
    for name, T in (("roll", roll(math.radians(120))), ("helicoid", helicoid(math.radians(60))),
                    ("bulge", bulge(0.2 * W))):
        T[held] = V[held]
        fixed = [dict(vertex=int(v)) for v in held] + [dict(vertex=int(v), position=T[v].tolist()) for v in handle]
        poses.append((name, fixed, T))
    return finish(scene, poses)


def mixed_case(rodmesh, tmp, cells, k):
    """Radii only: the shell's lift and twist, and a load-free pose whose
    target (a bulge) only a rest shape could reach."""
    shell = shell_case(rodmesh, tmp, cells, k, shell_motions(sheet_width(cells))[:2], 0.005)
    shape = shape_case(rodmesh, tmp, cells, k)
    bulge = [p for p in shape["poses"] if p["name"] == "bulge"][0]
    # Without gravity in the rod scene (the shell's targets keep its sag) the
    # bulge pose has no load at all: its held side and handle stay at rest.
    out = dict(shell)
    out.pop("gravity", None)
    out["poses"] = shell["poses"] + [bulge]
    out["design"] = dict(shell["design"], parameters=["radii"])
    return out


def shell_motions(W):
    return [("lift", rigid_handle(lift=0.25 * W)),
            ("twist", rigid_handle(twist=math.radians(45))),
            ("lift_twist_push", rigid_handle(lift=0.15 * W, twist=math.radians(25), push=0.15 * W))]


def variant_motions(W, scale, sign=1.0):
    """shell_motions scaled by `scale` (lift and push lengths, twist angle);
    sign -1 lowers the handle and twists it the other way."""
    return [("lift", rigid_handle(lift=sign * 0.25 * scale * W)),
            ("twist", rigid_handle(twist=sign * math.radians(45) * scale)),
            ("lift_twist_push", rigid_handle(lift=sign * 0.15 * scale * W, twist=sign * math.radians(25) * scale,
                                             push=0.15 * scale * W))]


def sheet_width(cells):
    return 0.025 * math.sqrt(3) * cells[0]


CASES = {
    "shell_small": lambda rm, tmp: shell_case(rm, tmp, (3, 3), 4, shell_motions(sheet_width((3, 3))), 0.005),
    "shape_small": lambda rm, tmp: shape_case(rm, tmp, (3, 3), 4),
    "mixed_small": lambda rm, tmp: mixed_case(rm, tmp, (3, 3), 4),
    "shell_large": lambda rm, tmp: shell_case(rm, tmp, (4, 5), 11, shell_motions(sheet_width((4, 5))), 0.005),
    # Variants of shell_small for an acceptance-style sweep (not in the
    # benchmark table): finer rods, larger and smaller motions, the motions
    # reversed, other soft regions, the default radius range, more cells.
    "var_fine": lambda rm, tmp: shell_case(rm, tmp, (3, 3), 7, shell_motions(sheet_width((3, 3))), 0.004),
    "var_big": lambda rm, tmp: shell_case(rm, tmp, (3, 3), 4, variant_motions(sheet_width((3, 3)), 1.6), 0.005),
    "var_gentle": lambda rm, tmp: shell_case(rm, tmp, (3, 3), 4, variant_motions(sheet_width((3, 3)), 0.4), 0.005),
    "var_down": lambda rm, tmp: shell_case(rm, tmp, (3, 3), 4, variant_motions(sheet_width((3, 3)), 1.0, -1.0),
                                           0.005),
    "var_uniform": lambda rm, tmp: shell_case(rm, tmp, (3, 3), 4, shell_motions(sheet_width((3, 3))), 0.005,
                                              soft="none"),
    "var_heldsoft": lambda rm, tmp: shell_case(rm, tmp, (3, 3), 4, shell_motions(sheet_width((3, 3))), 0.005,
                                               soft="held"),
    "var_nobounds": lambda rm, tmp: shell_case(rm, tmp, (3, 3), 4, shell_motions(sheet_width((3, 3))), 0.005,
                                               bounds=None),
    "var_wide": lambda rm, tmp: shell_case(rm, tmp, (2, 5), 4, shell_motions(sheet_width((2, 5))), 0.005),
    "var_long": lambda rm, tmp: shell_case(rm, tmp, (5, 2), 4, shell_motions(sheet_width((5, 2))), 0.005),
}


def simulate_positions(rodmesh, scene, tmp, tag):
    s = dict(scene)
    s.pop("design", None)
    path = os.path.join(tmp, tag + "_initial.json")
    with open(path, "w") as f:
        json.dump(s, f)
    out = path[:-5] + ".h5"
    r = subprocess.run([rodmesh, "simulate", path, "-o", out, "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True)
    if r.returncode != 0:
        raise Failure("simulate %s (initial design) exited %d:\n%s" % (tag, r.returncode, r.stderr[-2000:]))
    import h5py
    with h5py.File(out, "r") as f:
        return {p["name"]: f["poses"][p["name"]]["positions"][()] for p in scene["poses"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rodmesh", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--only", default="")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    names = [n for n in CASES if not a.only or n in a.only.split(",")]
    info = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            try:
                scene = CASES[name](a.rodmesh, tmp)
                q = simulate_positions(a.rodmesh, scene, tmp, name)
            except Failure as e:
                print("%s: %s" % (name, e), file=sys.stderr)
                sys.exit(1)
            with open(os.path.join(a.out, name + ".json"), "w") as f:
                json.dump(scene, f)
            per = {}
            for p in scene["poses"]:
                d = np.asarray(q[p["name"]]) - np.asarray(p["target"])
                per[p["name"]] = round(1e3 * math.sqrt((d ** 2).sum(1).mean()), 4)
            info[name] = dict(vertices=len(scene["vertices"]), rods=len(scene["rods"]), poses=len(scene["poses"]),
                              initial_rms_mm_per_pose=per)
            print(name, json.dumps(info[name]))
    with open(os.path.join(a.out, "cases.json"), "w") as f:
        json.dump(info, f, indent=1)


if __name__ == "__main__":
    main()
