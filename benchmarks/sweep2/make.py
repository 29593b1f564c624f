#!/usr/bin/python3
"""Second acceptance sweep for rodmesh: writes the scenes and their references.

    /usr/bin/python3 make.py [--rodmesh BIN] [--out DIR]

Writes DIR/NAME.json (scenes), DIR/cases.json (index: per case the kind, the
command to run and the reference to judge it by). Optimize cases need
`rodmesh simulate` of a hidden design to make their targets (one process at a
time). Closed forms: refs.py.
"""
import argparse
import copy
import json
import math
import os
import subprocess
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import refs  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RODMESH = os.path.join(ROOT, "build", "apps", "rodmesh")
OUT = "/tmp/rodmesh_sweep2/cases"

E = 3.2e7
NU = 0.48
RHO = 1200.0
G = E / (2 * (1 + NU))
MAT = {"young_modulus": E, "poisson_ratio": NU, "density": RHO}

CASES = []


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def write(name, scene):
    path = os.path.join(OUT, name + ".json")
    with open(path, "w") as f:
        json.dump(scene, f, indent=1)
    return path


def add(name, kind, scene=None, path=None, args=(), ref=None, group="", note=""):
    if scene is not None:
        path = write(name, scene)
    CASES.append({"name": name, "kind": kind, "group": group, "scene": path,
                  "args": list(args), "ref": ref or {}, "note": note})


def straight(origin, d, L, n):
    origin = np.asarray(origin, float)
    return [list(origin + d * (L * i / n)) for i in range(n + 1)]


def base(vertices, rods, radius, poses, **kw):
    s = {"format": "rodmesh-scene/1", "material": dict(MAT), "vertices": vertices,
         "rods": rods, "radius": list(radius), "poses": poses}
    s.update(kw)
    return s


def to3(origin, e1, e2, x, y):
    return list(np.asarray(origin) + x * e1 + y * e2)


# ---------------------------------------------------------------- 1. closed forms
ORIG = np.array([0.01, -0.02, 0.03])
D = unit([1, 2, 2])          # rod direction (diagonal)
NPERP = unit([2, 1, -2])     # perpendicular to D
BPERP = np.cross(NPERP, D)   # D1 = D2 x T for normal NPERP


def elastica_cases():
    L, r = 0.2, 0.001
    EI = E * math.pi * r ** 4 / 4
    # (alpha = P L^2/EI) levels at 40 edges, convergence at alpha = 10
    runs = [(a, 40) for a in (0.5, 2.0, 10.0, 40.0)] + [(10.0, n) for n in (10, 20, 80)]
    for alpha, n in runs:
        P = alpha * EI / L ** 2
        ref = refs.elastica_bvp(L, EI, P=(0.0, P))
        tip = to3(ORIG, D, NPERP, ref["x"], ref["y"])
        sc = base(straight(ORIG, D, L, n), [{"vertices": list(range(n + 1))}], [r, r],
                  [{"name": "tip", "clamped": [{"vertex": 0}],
                    "forces": [{"vertex": n, "force": list(P * NPERP)}]}])
        add("elastica_a%g_n%d" % (alpha, n), "closed", sc, group="elastica",
            ref={"checks": [{"pose": "tip", "vertex": n, "expected": tip}], "rest_tip": list(ORIG + L * D),
                 "edges": n, "formula": "planar elastica, dead tip load, shooting; alpha=PL^2/EI=%g" % alpha})


def pure_bending_cases():
    """Rod A (clamped) bent by a moment transmitted by a perpendicular lever B (along
    +z) twisted by a twisting moment at its free end: constant moment M about z along
    A: exact circle arc, curvature M/EI, phi = M L/EI."""
    L, r, c = 0.2, 0.001, 0.02
    EI = E * math.pi * r ** 4 / 4
    d = unit([1, 2, 0])
    z = np.array([0.0, 0.0, 1.0])
    b = np.cross(z, d)
    runs = [(p, 40) for p in (0.5, 1.2, 1.8)] + [(1.2, n) for n in (10, 20, 80)]
    for phi_pi, n in runs:
        phi = phi_pi * math.pi
        M = phi * EI / L
        R = L / phi
        verts = straight(ORIG, d, L, n)
        tipA = np.asarray(verts[-1])
        nb = 4
        verts += [list(tipA + z * c * (i / nb)) for i in range(1, nb + 1)]
        rods = [{"vertices": list(range(n + 1))}, {"vertices": [n] + list(range(n + 1, n + 1 + nb))}]
        sc = base(verts, rods, [r, r],
                  [{"name": "bend", "clamped": [{"vertex": 0}],
                    "twisting_moments": [{"vertex": n + nb, "moment": M}]}])
        tip = ORIG + R * math.sin(phi) * d + R * (1 - math.cos(phi)) * b
        add("purebend_phi%gpi_n%d" % (phi_pi, n), "closed", sc, group="pure_bending",
            ref={"checks": [{"pose": "bend", "vertex": n, "expected": list(tip)},
                            {"pose": "bend", "vertex": n + nb, "expected": list(tip + c * z)}],
                 "rest_tip": list(tipA), "edges": n,
                 "formula": "circle arc kappa=M/EI, phi=ML/EI=%g pi (moment via twisted lever along z)" % phi_pi})


def prescribed_arc_cases():
    """Planar: vertex 0 clamped, the last two vertices prescribed (fixed with
    position) onto the circle arc of end angle phi: the exact solution is that arc
    (pure bending, zero end force), every vertex on the circle of radius L/phi."""
    L, r = 0.2, 0.001
    d = unit([1, 2, 0])
    b = np.cross([0.0, 0.0, 1.0], d)
    for phi_pi, n in ((0.5, 40), (0.9, 40), (1.2, 40), (1.2, 80)):
        phi = phi_pi * math.pi
        R = L / phi
        arc = lambda s: ORIG + R * math.sin(phi * s / L) * d + R * (1 - math.cos(phi * s / L)) * b
        h = L / n
        # the discrete arc's last edge is a chord: put the two held vertices on the circle
        held = [{"vertex": n - 1, "position": list(arc(L - h))}, {"vertex": n, "position": list(arc(L))}]
        sc = base(straight(ORIG, d, L, n), [{"vertices": list(range(n + 1))}], [r, r],
                  [{"name": "arc", "clamped": [{"vertex": 0}], "fixed": held}])
        mid = n // 2
        add("prescribed_arc_phi%gpi_n%d" % (phi_pi, n), "closed", sc, group="pure_bending",
            ref={"checks": [{"pose": "arc", "vertex": mid, "expected": list(arc(L * mid / n))},
                            {"pose": "arc", "vertex": n // 4, "expected": list(arc(L * (n // 4) / n))}],
                 "edges": n, "formula": "circle arc through prescribed end (phi=%g pi); planar scene" % phi_pi})


def ring_cases():
    """Ring of radius R (two half-circle rods joined at bottom and top), bottom
    connection clamped, top pushed down by P: pinched ring, small load:
    top moves down (pi/4 - 2/pi) P R^3/EI, sides out by (2/pi - 1/2)/2 P R^3/EI."""
    R, r = 0.05, 0.001
    EI = E * math.pi * r ** 4 / 4
    for n in (16, 32, 64, 128):
        verts = [[R * math.sin(2 * math.pi * i / n), -R * math.cos(2 * math.pi * i / n), 0.0] for i in range(n)]
        h = n // 2
        rods = [{"vertices": list(range(0, h + 1))}, {"vertices": list(range(h, n)) + [0]}]
        delta_target = 1e-4 * R
        P = delta_target * EI / ((math.pi / 4 - 2 / math.pi) * R ** 3)
        dv = (math.pi / 4 - 2 / math.pi) * P * R ** 3 / EI
        dh = (2 / math.pi - 0.5) * P * R ** 3 / EI / 2
        sc = base(verts, rods, [r, r],
                  [{"name": "pinch", "clamped": [{"vertex": 0}],
                    "forces": [{"vertex": h, "force": [0.0, -P, 0.0]}]}])
        add("ring_pinch_n%d" % n, "closed", sc, group="ring",
            ref={"checks": [{"pose": "pinch", "vertex": h, "expected": [0.0, R - dv, 0.0]},
                            {"pose": "pinch", "vertex": n // 4, "expected": [R + dh, -dv / 2, 0.0]},
                            {"pose": "pinch", "vertex": 3 * n // 4, "expected": [-R - dh, -dv / 2, 0.0]}],
                 "rest_tip": [0.0, R, 0.0], "edges": n, "disp_scale": dv,
                 "formula": "pinched ring, linear (pi/4-2/pi) PR^3/EI, delta/R=1e-4"})
    # one rod closing on itself (first vertex = last): edge case of the format
    n = 32
    verts = [[R * math.sin(2 * math.pi * i / n), -R * math.cos(2 * math.pi * i / n), 0.0] for i in range(n)]
    P = 1e-4 * R * EI / ((math.pi / 4 - 2 / math.pi) * R ** 3)
    sc = base(verts, [{"vertices": list(range(n)) + [0]}], [r, r],
              [{"name": "pinch", "clamped": [{"vertex": 0}], "forces": [{"vertex": n // 2, "force": [0.0, -P, 0.0]}]}])
    add("ring_single_rod_closed", "edge", sc, group="ring",
        note="one rod whose last vertex is its first: either a clear exit-2 message or the ring solution")


def column_cases():
    L, r = 0.2, 0.001
    EI = E * math.pi * r ** 4 / 4
    Pcr = math.pi ** 2 * EI / (4 * L * L)
    eps = 1e-3
    runs = [(f, 40) for f in (0.95, 1.02, 1.1, 1.5, 3.0)] + [(1.1, n) for n in (10, 20, 80)]
    for f, n in runs:
        P = f * Pcr
        ref = refs.column_imperfect(L, EI, P, eps)
        tip = to3(ORIG, D, NPERP, ref["x"], ref["y"])
        force = list(-P * D + eps * P * NPERP)
        sc = base(straight(ORIG, D, L, n), [{"vertices": list(range(n + 1))}], [r, r],
                  [{"name": "column", "clamped": [{"vertex": 0}],
                    "forces": [{"vertex": n, "force": force}]}])
        extra = {}
        if f > 1:
            xp, yp, _ = refs.column_postbuckling(L, EI, P)
            extra["perfect_tip_xy"] = [xp, yp]
        add("column_%gPcr_n%d" % (f, n), "closed", sc, group="column",
            ref=dict({"checks": [{"pose": "column", "vertex": n, "expected": tip}],
                      "rest_tip": list(ORIG + L * D), "edges": n,
                      "formula": "clamped-free column P=%g Pcr, lateral imperfection 1e-3 P, elastica shooting" % f},
                     **extra))


def twist_cases():
    L, r = 0.2, 0.001
    EI = E * math.pi * r ** 4 / 4
    GJ = G * math.pi * r ** 4 / 2
    n = 40
    h = L / n
    for th in (0.5, 2.0, 3.5, 4.3):
        M = th * GJ / L
        sc = base(straight(ORIG, D, L, n), [{"vertices": list(range(n + 1))}], [r, r],
                  [{"name": "twist", "clamped": [{"vertex": 0}],
                    "twisting_moments": [{"vertex": n, "moment": M}]}])
        add("twist_theta%g" % th, "closed", sc, group="twist",
            ref={"twist_checks": [{"pose": "twist", "edge": n - 1, "expected": M * (L - h / 2) / GJ}],
                 "checks": [{"pose": "twist", "vertex": n, "expected": list(ORIG + L * D)}],
                 "rest_tip": list(ORIG + L * D), "edges": n,
                 "formula": "theta = M L/GJ (last edge at s = L - h/2); tip must not move"})
    # above a Greenhill-type critical torque (docs/model.md: ~pi EI/L loses the path)
    M = 1.5 * math.pi * EI / L
    sc = base(straight(ORIG, D, L, n), [{"vertices": list(range(n + 1))}], [r, r],
              [{"name": "twist", "clamped": [{"vertex": 0}],
                "twisting_moments": [{"vertex": n, "moment": M}]}])
    add("twist_above_critical", "edge", sc, group="twist",
        note="M = 1.5 pi EI/L: above the critical torque: expect a reported critical point or a clear not_converged")


def ellipse_cases():
    """Elliptical section r_t = 2 mm, r_n = 1 mm; rod along D, normals NPERP.
    Bending toward the normal: I = pi r_t r_n^3/4; in the tangent plane (along D1 =
    normal x tangent): I = pi r_t^3 r_n/4 (docs/model.md)."""
    L, rt, rn = 0.2, 0.002, 0.001
    Iw = math.pi * rt * rn ** 3 / 4
    Is = math.pi * rt ** 3 * rn / 4
    n = 40
    for label, direction, I, alpha in (("normal", NPERP, Iw, 2.0), ("binormal", BPERP, Is, 0.3),
                                       ("normal_small", NPERP, Iw, 0.01), ("binormal_small", BPERP, Is, 0.01)):
        EI = E * I
        P = alpha * EI / L ** 2
        ref = refs.elastica_bvp(L, EI, P=(0.0, P))
        tip = to3(ORIG, D, direction, ref["x"], ref["y"])
        sc = base(straight(ORIG, D, L, n), [{"vertices": list(range(n + 1))}], [rt, rn],
                  [{"name": "tip", "clamped": [{"vertex": 0}],
                    "forces": [{"vertex": n, "force": list(P * direction)}]}],
                  normals=[list(NPERP)] * (n + 1))
        add("ellipse_%s_a%g" % (label, alpha), "closed", sc, group="ellipse",
            ref={"checks": [{"pose": "tip", "vertex": n, "expected": tip}], "rest_tip": list(ORIG + L * D),
                 "edges": n, "formula": "elastica with I=%s, alpha=%g" % ("pi rt rn^3/4" if I == Iw else "pi rt^3 rn/4", alpha)})
    # every normal parallel to the rod (degenerate frame): bad input, expect exit 2
    sc = base(straight(ORIG, D, L, n), [{"vertices": list(range(n + 1))}], [rt, rn],
              [{"name": "tip", "clamped": [{"vertex": 0}],
                "forces": [{"vertex": n, "force": list(2.0 * E * Iw / L ** 2 * NPERP)}]}],
              normals=[list(D)] * (n + 1))
    add("ellipse_normals_parallel_to_rod", "edge", sc, group="ellipse",
        note="normals parallel to the tangent: expect exit 2 naming normals[v], or a correct solve; never converged with a large residual")
    # beyond lateral-torsional buckling (load in the stiff plane)
    EIw, EIs = E * Iw, E * Is
    GJ = G * math.pi * rt ** 3 * rn ** 3 / (rt ** 2 + rn ** 2)
    Pcr = 4.013 * math.sqrt(EIw * GJ) / L ** 2 / math.sqrt((1 - EIw / EIs) * (1 - GJ / EIs))
    P = 2.0 * Pcr
    sc = base(straight(ORIG, D, L, n), [{"vertices": list(range(n + 1))}], [rt, rn],
              [{"name": "tip", "clamped": [{"vertex": 0}],
                "forces": [{"vertex": n, "force": list(P * BPERP)}]}],
              normals=[list(NPERP)] * (n + 1))
    add("ellipse_binormal_lateral_buckling", "edge", sc, group="ellipse",
        ref={"lateral_buckling_load_factor": Pcr / P},
        note="load in the stiff plane at ~2x the lateral-torsional buckling load (closed form with pre-buckling correction, crude at rt/rn=2): expect a critical point near load factor %.3f" % (Pcr / P))


def gravity_cases():
    r = 0.0005
    EI = E * math.pi * r ** 4 / 4
    wmag = RHO * 9.81 * math.pi * r * r
    d = unit([2, 1, 0])
    up = np.array([0.0, 0.0, 1.0])
    runs = [(0.15, 40), (0.3, 40), (0.3, 10), (0.3, 20), (0.3, 80)]
    for L, n in runs:
        ref = refs.elastica_bvp(L, EI, w=(0.0, -wmag))
        tip = to3(ORIG, d, up, ref["x"], ref["y"])
        sc = base(straight(ORIG, d, L, n), [{"vertices": list(range(n + 1))}], [r, r],
                  [{"name": "sag", "clamped": [{"vertex": 0}]}], gravity=[0.0, 0.0, -9.81])
        add("gravity_L%g_n%d" % (L, n), "closed", sc, group="gravity",
            ref={"checks": [{"pose": "sag", "vertex": n, "expected": tip}], "rest_tip": list(ORIG + L * d),
                 "edges": n, "formula": "heavy elastica, wL^3/EI=%.1f" % (wmag * L ** 3 / EI)})


# ---------------------------------------------------------------- 2. planar patches
def planar_cases():
    for kind, cells, k in (("hex", (3, 3), 7), ("quad", (3, 3), 7)):
        path = os.path.join(OUT, "grid_%s.json" % kind)
        subprocess.run([RODMESH, "mesh", "--grid", kind, "--size", "0.1", "0.1", "--cells", str(cells[0]),
                        str(cells[1]), "--rod-vertices", str(k), "--radius", "0.0005", "--radius-bounds", "0.0002", "0.002", "--fix-side", "left",
                        "--pull", "right", "1", "0", "0", "-o", path, "-q"], check=True)
        g = json.load(open(path))
        pull = g["poses"][0]
        nload = len(pull["forces"])
        for k2 in ("design", "gravity"):
            g.pop(k2, None)
        # load directions and total forces [N]: tension (stable in plane), shear
        # (in-plane shear buckles sideways at some load), compression
        for label, dirn, levels in (("tension", (1, 0), (0.01, 0.3, 10.0, 300.0)),
                                    ("shear", (0, 1), (0.001, 0.01, 0.1)),
                                    ("compress", (-1, 0), (0.01, 0.1, 1.0))):
            for F in levels:
                s = copy.deepcopy(g)
                f = [dirn[0] * F / nload, dirn[1] * F / nload, 0.0]
                s["poses"] = [{"name": "load", "fixed": pull.get("fixed", []),
                               "clamped": pull.get("clamped", []),
                               "forces": [{"vertex": fo["vertex"], "force": f} for fo in pull["forces"]]}]
                for k3 in list(s["poses"][0]):
                    if s["poses"][0][k3] == []:
                        del s["poses"][0][k3]
                name = "planar_%s_%s_%gN" % (kind, label, F)
                if F >= 0.01:
                    sc = copy.deepcopy(s)
                    held = sc["poses"][0].pop("fixed", [])
                    sc["poses"][0]["clamped"] = [{"vertex": h["vertex"]} for h in held] + sc["poses"][0].get("clamped", [])
                    add(name.replace("planar_", "planarclamped_"), "planar", sc, group="planarclamped_" + kind,
                        ref={"load_dir": label, "total_force": F},
                        note="left side clamped (not a hinge)")
                    if (kind, label, F) == ("hex", "shear", 0.1):
                        add(name.replace("planar_", "planarclamped_") + "_dynamic", "planar_dynamic",
                            path=os.path.join(OUT, name.replace("planar_", "planarclamped_") + ".json"),
                            args=["--dynamic", "--duration", "3", "--ramp", "2", "--time-limit", "120"], group="planarclamped_" + kind,
                            ref={"static_case": name.replace("planar_", "planarclamped_")})
                add(name, "planar", s, group="planar_" + kind,
                    ref={"load_dir": label, "total_force": F},
                    note="in-plane load; planar solve; stays in plane when in-plane stable")
                if (label, F) in (("shear", 0.1), ("tension", 10.0), ("compress", 1.0)) and kind == "hex":
                    add(name + "_dynamic", "planar_dynamic", path=os.path.join(OUT, name + ".json"),
                        args=["--dynamic", "--duration", "3", "--ramp", "2", "--time-limit", "120"], group="planar_" + kind,
                        ref={"static_case": name})


# ---------------------------------------------------------------- 3. bad inputs
def bad_cases():
    n = 4
    good = base(straight([0, 0, 0], np.array([1.0, 0, 0]), 0.1, n), [{"vertices": list(range(n + 1))}],
                [0.001, 0.001], [{"name": "p", "clamped": [{"vertex": 0}],
                                  "forces": [{"vertex": n, "force": [0, 0, -1e-4]}]}])
    add("bad_control_good", "bad", good, ref={"expect_exit": 0}, group="bad", note="the valid base scene")
    txt = json.dumps(good, indent=1)

    def mut(name, fn, expect=2, note=""):
        s = copy.deepcopy(good)
        r = fn(s)
        if isinstance(r, dict):
            s = r
        add("bad_" + name, "bad", s, ref={"expect_exit": expect}, group="bad", note=note)

    def raw(name, text, expect=2, note=""):
        path = os.path.join(OUT, "bad_" + name + ".json")
        with open(path, "w") as f:
            f.write(text)
        add("bad_" + name, "bad", path=path, ref={"expect_exit": expect}, group="bad", note=note)

    raw("truncated", txt[: len(txt) // 2])
    raw("empty_file", "")
    raw("top_array", "[]")
    raw("nan_literal_E", txt.replace('"young_modulus": %s' % json.dumps(E), '"young_modulus": NaN'))
    raw("inf_literal_radius", txt.replace('"radius": [\n  0.001', '"radius": [\n  Infinity'))
    raw("number_1e999_density", txt.replace('"density": 1200.0', '"density": 1e999'))
    raw("duplicate_key_radius", txt.replace('"radius": [', '"radius": [0.5, 0.5], "radius": ['),
        note="duplicate JSON key (first value out of range): which one counts should be stated or rejected")
    raw("trailing_garbage", txt + "\n}}")
    raw("utf8_bom", "\ufeff" + txt, expect=None, note="BOM: either accepted or a clear message")
    raw("deep_nesting", '{"format": "rodmesh-scene/1", "x": ' + "[" * 100 + "]" * 100 + "}")
    mut("E_string", lambda s: s["material"].__setitem__("young_modulus", "3.2e7"))
    mut("E_negative", lambda s: s["material"].__setitem__("young_modulus", -3.2e7))
    mut("E_zero", lambda s: s["material"].__setitem__("young_modulus", 0))
    mut("density_negative", lambda s: s["material"].__setitem__("density", -1.0))
    mut("density_zero", lambda s: s["material"].__setitem__("density", 0.0))
    mut("poisson_half", lambda s: s["material"].__setitem__("poisson_ratio", 0.5))
    mut("poisson_minus1", lambda s: s["material"].__setitem__("poisson_ratio", -1.0))
    mut("radius_negative", lambda s: s.__setitem__("radius", [-0.001, 0.001]))
    mut("radius_zero", lambda s: s.__setitem__("radius", [0.001, 0.0]))
    mut("radius_one_value", lambda s: s.__setitem__("radius", [0.001]))
    mut("radius_scalar", lambda s: s.__setitem__("radius", 0.001))
    mut("radii_wrong_count", lambda s: (s.pop("radius"), s.__setitem__("radii", [[0.001, 0.001]] * 3)))
    mut("radii_nan_string", lambda s: (s.pop("radius"), s.__setitem__("radii", [[0.001, 0.001]] * 4 + [["nan", 0.001]])))
    mut("no_radius", lambda s: s.pop("radius"))
    mut("rod_index_oob", lambda s: s["rods"][0]["vertices"].__setitem__(4, 99))
    mut("rod_index_negative", lambda s: s["rods"][0]["vertices"].__setitem__(4, -1))
    mut("rod_index_2pow32", lambda s: s["rods"][0]["vertices"].__setitem__(0, 4294967296),
        note="2^32 would wrap to 0 in a 32-bit int")
    mut("rod_index_2pow32_plus4", lambda s: s["rods"][0]["vertices"].__setitem__(4, 4294967300),
        note="2^32+4 would wrap to 4 in a 32-bit int: scene would otherwise be valid")
    mut("rod_index_float", lambda s: s["rods"][0]["vertices"].__setitem__(4, 4.0),
        expect=None, note="4.0 for 4: accept or reject, clearly")
    mut("rod_index_float_frac", lambda s: s["rods"][0]["vertices"].__setitem__(4, 3.5))
    mut("rod_index_bool", lambda s: s["rods"][0]["vertices"].__setitem__(1, True))
    mut("fixed_oob", lambda s: s["poses"][0].__setitem__("fixed", [{"vertex": 5}]))
    mut("clamped_oob", lambda s: s["poses"][0].__setitem__("clamped", [{"vertex": 7}]))
    mut("clamped_2pow32", lambda s: s["poses"][0].__setitem__("clamped", [{"vertex": 4294967296}]),
        note="2^32 would wrap to 0 (a valid clamp)")
    mut("force_oob", lambda s: s["poses"][0]["forces"][0].__setitem__("vertex", 5))
    mut("force_2pow32_plus4", lambda s: s["poses"][0]["forces"][0].__setitem__("vertex", 4294967300),
        note="would wrap to 4, the valid loaded vertex")
    mut("force_nan_string", lambda s: s["poses"][0]["forces"][0].__setitem__("force", [0, "NaN", 0]))
    mut("force_two_components", lambda s: s["poses"][0]["forces"][0].__setitem__("force", [0, -1e-4]))
    mut("force_on_clamped", lambda s: s["poses"][0]["forces"].append({"vertex": 0, "force": [0, 0, 1.0]}),
        expect=None, note="force on a held vertex: warn or reject?")
    mut("target_wrong_count", lambda s: s["poses"][0].__setitem__("target", [[0, 0, 0]] * 3))
    mut("vertex_two_coords", lambda s: s["vertices"].__setitem__(2, [0.05, 0.0]))
    mut("vertex_four_coords", lambda s: s["vertices"].__setitem__(2, [0.05, 0.0, 0.0, 1.0]))
    mut("vertex_null", lambda s: s["vertices"].__setitem__(2, None))
    mut("duplicate_vertex_zero_edge", lambda s: s["vertices"].__setitem__(2, list(s["vertices"][1])))
    mut("repeated_index_in_rod", lambda s: s["rods"][0].__setitem__("vertices", [0, 1, 1, 2, 3, 4]))
    mut("rod_one_vertex", lambda s: s["rods"].append({"vertices": [4]}))
    mut("rod_empty", lambda s: s["rods"].append({"vertices": []}))
    mut("rods_empty", lambda s: s.__setitem__("rods", []))
    mut("vertices_empty", lambda s: (s.__setitem__("vertices", []), s.__setitem__("rods", [])))
    mut("vertex_in_no_rod", lambda s: s["vertices"].append([0.2, 0.0, 0.0]))
    mut("vertex_shared_midrod", lambda s: s["rods"].append({"vertices": [2, 4]}),
        note="vertex 2 interior of rod 0 and end of rod 1")
    mut("coincident_unconnected_vertices", lambda s: (s["vertices"].extend([[0.05, 0.0, 0.0], [0.05, 0.05, 0.0]]),
                                                      s["rods"].append({"vertices": [5, 6]})),
        expect=None, note="a second rod starting at the same point as vertex 2 but not connected; rod 6 free")
    mut("poses_empty", lambda s: s.__setitem__("poses", []))
    mut("poses_missing", lambda s: s.pop("poses"))
    mut("pose_name_slash", lambda s: s["poses"][0].__setitem__("name", "a/b"))
    mut("pose_names_duplicate", lambda s: s["poses"].append(copy.deepcopy(s["poses"][0])),
        note="two poses named p: archive groups would collide")
    mut("pose_no_name", lambda s: s["poses"][0].pop("name"), expect=None)
    mut("unknown_keys", lambda s: (s.__setitem__("colour", "red"), s["poses"][0].__setitem__("forcez", [])),
        expect=0, note="contract: warnings, ignored, run proceeds")
    mut("format_wrong", lambda s: s.__setitem__("format", "rodmesh-scene/2"))
    mut("format_missing", lambda s: s.pop("format"), expect=None)
    mut("gravity_two", lambda s: s.__setitem__("gravity", [0, -9.81]))
    mut("gravity_huge", lambda s: s.__setitem__("gravity", [0, 0, -1e5]))
    mut("normals_parallel", lambda s: s.__setitem__("normals", [[1, 0, 0]] * 5),
        note="normal parallel to the rod tangent: undefined frame")
    mut("normals_zero", lambda s: s.__setitem__("normals", [[0, 0, 0]] * 5))
    mut("normals_wrong_count", lambda s: s.__setitem__("normals", [[0, 0, 1]] * 2))
    mut("effects_no_stretch", lambda s: s.__setitem__("effects", ["bend"]))
    mut("effects_unknown", lambda s: s.__setitem__("effects", ["stretch", "bend", "magnetism"]))
    mut("twisting_moment_interior", lambda s: s["poses"][0].__setitem__("twisting_moments", [{"vertex": 2, "moment": 1e-4}]))
    mut("twisting_moment_on_clamped_end", lambda s: s["poses"][0].__setitem__("twisting_moments", [{"vertex": 0, "moment": 1e-4}]),
        expect=None)
    mut("fixed_and_clamped_same", lambda s: s["poses"][0].__setitem__("fixed", [{"vertex": 0, "position": [0, 0, 0.01]}]),
        note="vertex 0 clamped at rest and fixed elsewhere: contradictory")
    mut("fixed_position_nan", lambda s: s["poses"][0].__setitem__("fixed", [{"vertex": 4, "position": [0.1, "nan", 0]}]))
    mut("weight_negative", lambda s: s["poses"][0].__setitem__("weight", -1.0), expect=None,
        note="formats.md: negative weight is rejected by optimize; simulate?")
    mut("coordinate_1e7", lambda s: s["vertices"].__setitem__(4, [1e7, 0, 0]))
    mut("unsupported_everything_free", lambda s: s["poses"][0].pop("clamped"), expect=None,
        note="no support at all with a force: rigid-body motion; expect exit 1 with a clear message (or 2)")
    # huge file (sparse): > 256 MiB by stat
    path = os.path.join(OUT, "bad_huge_sparse.json")
    with open(path, "w") as f:
        f.write(txt)
    os.truncate(path, 300 * 1024 * 1024)
    add("bad_huge_sparse", "bad", path=path, ref={"expect_exit": 2}, group="bad",
        note="300 MiB (sparse) > 256 MiB limit")
    # an archive given as a scene
    add("bad_archive_as_scene", "bad", path="__ARCHIVE__", ref={"expect_exit": 2}, group="bad")
    # output pre-existing: a bad scene must leave it unchanged
    add("bad_existing_output_kept", "bad", path=os.path.join(OUT, "bad_E_negative.json"),
        ref={"expect_exit": 2, "preexisting_output": True}, group="bad")
    # optimize on bad design blocks
    og = copy.deepcopy(good)
    og["poses"][0]["target"] = [list(v) for v in good["vertices"]]
    og["design"] = {"parameters": ["radii"], "radius_bounds": [0.0005, 0.002], "control_points_per_rod": 3}
    for name, fn in (("opt_bounds_reversed", lambda s: s["design"].__setitem__("radius_bounds", [0.002, 0.0005])),
                     ("opt_param_unknown", lambda s: s["design"].__setitem__("parameters", ["radii", "stiffness"])),
                     ("opt_cp_1", lambda s: s["design"].__setitem__("control_points_per_rod", 1)),
                     ("opt_radius_outside_bounds", lambda s: s.__setitem__("radius", [0.003, 0.001])),
                     ("opt_no_target", lambda s: s["poses"][0].pop("target")),
                     ("opt_target_nan", lambda s: s["poses"][0]["target"].__setitem__(2, [0, "nan", 0]))):
        s = copy.deepcopy(og)
        fn(s)
        add("bad_" + name, "bad_optimize", s, ref={"expect_exit": 2}, group="bad")


# ---------------------------------------------------------------- 4. optimize
def simulate_positions(scene, tag):
    path = os.path.join(OUT, "hidden", tag + ".json")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    json.dump(scene, open(path, "w"), indent=1)
    out = path[:-5] + ".h5"
    r = subprocess.run([RODMESH, "simulate", path, "-o", out, "-q"], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError("hidden simulate %s: %d %s" % (tag, r.returncode, r.stderr))
    with h5py.File(out, "r") as f:
        return {p["name"]: f["poses"][p["name"]]["positions"][()] for p in scene["poses"]}


def optimize_cases():
    # (a) an L-shaped 3D frame of three rods (a tripod leg with an elbow): radii
    L = 0.1
    k = 8
    A = np.array([0.0, 0.0, 0.0])
    B = np.array([0.0, 0.0, L])
    C = np.array([L, 0.0, L])
    Dd = np.array([L, L * 0.6, L * 0.7])
    verts, rods = [], []

    def seg(p, q, first_idx=None):
        idx = []
        for i in range(k + 1):
            if i == 0 and first_idx is not None:
                idx.append(first_idx)
                continue
            verts.append(list(p + (q - p) * i / k))
            idx.append(len(verts) - 1)
        rods.append({"vertices": idx})
        return idx[-1]

    b = seg(A, B)
    c = seg(B, C, b)
    seg(C, Dd, c)
    nv = len(verts)
    frame = base(verts, rods, [0.002, 0.002],
                 [{"name": "load_y", "clamped": [{"vertex": 0}], "forces": [{"vertex": nv - 1, "force": [0, 0.05, 0]}]},
                  {"name": "load_z", "clamped": [{"vertex": 0}], "forces": [{"vertex": nv - 1, "force": [0.02, 0, -0.04]}]}],
                 gravity=[0, 0, -9.81])
    frame["design"] = {"parameters": ["radii"], "radius_bounds": [0.001, 0.004], "control_points_per_rod": 3}
    V = np.asarray(verts)
    hid = copy.deepcopy(frame)
    hid.pop("radius")
    # linear in position: reproduced exactly by the per-rod Bernstein design space
    hid["radii"] = [[0.002 * (1 + 3 * v[0] - 2 * v[2]), 0.002 * (1 - 2 * v[2] + 1.5 * v[1])] for v in V]
    hid.pop("design")
    pos = simulate_positions(hid, "frame_radii")
    for p in frame["poses"]:
        p["target"] = pos[p["name"]].tolist()
    add("opt_frame_radii", "optimize", frame, group="optimize",
        note="3-rod 3D frame, gravity + tip forces, hidden radii linear in position")

    # (b) small hex sheet (planar) with radii and rest shape: sag under gravity + pull
    path = os.path.join(OUT, "grid_opt.json")
    subprocess.run([RODMESH, "mesh", "--grid", "hex", "--size", "0.06", "0.06", "--cells", "2", "2",
                    "--rod-vertices", "5", "--radius", "0.0015", "--fix-side", "left",
                    "--pull", "right", "0", "0", "-0.02", "-o", path, "-q"], check=True)
    g = json.load(open(path))
    g.pop("gravity", None)
    g["design"] = {"parameters": ["radii", "rest_shape"], "radius_bounds": [0.0008, 0.003], "control_points_per_rod": 3}
    V = np.asarray(g["vertices"])
    hid = copy.deepcopy(g)
    hid.pop("design")
    hid.pop("radius", None)
    hid.pop("radii", None)
    hid["radii"] = [[0.0015 * (1 + 6 * v[0]), 0.0015 * (1 - 4 * v[0] + 3 * v[1])] for v in V]
    hid["vertices"] = [[v[0] + 0.05 * v[1] * 0.2, v[1] + 0.03 * v[0], v[2]] for v in V]
    # supports move with the rest shape (clamped/fixed without position): fine
    pos = simulate_positions(hid, "sheet_both")
    for p in g["poses"]:
        p["target"] = pos[p["name"]].tolist()
    add("opt_sheet_both", "optimize", g, group="optimize",
        note="2x2 hex sheet, radii + rest shape, hidden linear radii and affine rest map")

    # (c) a single arc (3D) radii only, two poses
    n = 16
    R = 0.05
    verts = [[R * math.cos(math.pi * i / n), 0.3 * R * math.sin(math.pi * i / n), R * math.sin(math.pi * i / n)] for i in range(n + 1)]
    arc = base(verts, [{"vertices": list(range(n + 1))}], [0.0015, 0.001],
               [{"name": "push", "clamped": [{"vertex": 0}], "fixed": [{"vertex": n}],
                 "forces": [{"vertex": n // 2, "force": [0, 0.01, -0.03]}]},
                {"name": "sway", "clamped": [{"vertex": 0}, {"vertex": n}],
                 "forces": [{"vertex": n // 2, "force": [0.02, 0.02, 0]}]}])
    arc["design"] = {"parameters": ["radii"], "radius_bounds": [0.0005, 0.003], "control_points_per_rod": 4}
    hid = copy.deepcopy(arc)
    hid.pop("design")
    hid.pop("radius")
    s = np.linspace(0, 1, n + 1)
    # cubic Bernstein in the arc fraction (arc fraction = i/n: uniform chords)
    cp = np.array([[0.0015, 0.001], [0.0022, 0.0008], [0.0012, 0.0013], [0.0018, 0.0009]])
    Bm = np.stack([(1 - s) ** 3, 3 * s * (1 - s) ** 2, 3 * s ** 2 * (1 - s), s ** 3], 1)
    hid["radii"] = (Bm @ cp).tolist()
    pos = simulate_positions(hid, "arc_radii")
    for p in arc["poses"]:
        p["target"] = pos[p["name"]].tolist()
    add("opt_arc_radii", "optimize", arc, group="optimize",
        note="3D arch, elliptical sections, two poses, hidden cubic radii (exactly in the design space)")


def main():
    global RODMESH, OUT
    ap = argparse.ArgumentParser()
    ap.add_argument("--rodmesh", default=RODMESH)
    ap.add_argument("--out", default=OUT)
    a = ap.parse_args()
    RODMESH, OUT = a.rodmesh, a.out
    os.makedirs(OUT, exist_ok=True)
    elastica_cases()
    pure_bending_cases()
    prescribed_arc_cases()
    ring_cases()
    column_cases()
    twist_cases()
    ellipse_cases()
    gravity_cases()
    planar_cases()
    bad_cases()
    optimize_cases()
    json.dump(CASES, open(os.path.join(OUT, "cases.json"), "w"), indent=1)
    print("%d cases in %s" % (len(CASES), OUT))


if __name__ == "__main__":
    main()
