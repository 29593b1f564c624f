#!/usr/bin/env python3
"""The paper's Sheet experiment (Perez et al. 2015, Fig. 6, Table 1) as a scene
for `rodmesh optimize`: the 0.2 m hexagonal sheet of examples/sheet.json
(71 rods, 54 connections, 693 vertices) with four opposing target poses, each
the equilibrium of a *different* design and support:
  hang_left   clamped on the left side, own weight, soft out-of-plane bending
              (r_n = 1.2 mm, r_t = 2.5 mm);
  hang_right  clamped on the right side, own weight, stiff out-of-plane
              bending (r_n = 3.5 mm, r_t = 1.5 mm);
  pull_right  clamped on the left side, 0.3 N pulling the right side in +x,
  pull_up     clamped at the bottom, 0.3 N pulling the top in +y, both with
              the same thin in-plane section (r_t = 1.3 mm, r_n = 2 mm): the
              same stretch in both directions.
The design to optimize starts uniform (2 mm x 2 mm), radii and rest shape free,
radius bounds [1, 5] mm, 4 control points per rod.

usage: design_sheet.py RODMESH OUT.json   (writes OUT.json; uses a temp dir)
"""
import json, os, subprocess, sys, tempfile

import h5py
import numpy as np

rodmesh, out = sys.argv[1], sys.argv[2]
here = os.path.dirname(os.path.abspath(__file__))
base = json.load(open(os.path.join(here, "..", "examples", "sheet.json")))
V = np.array(base["vertices"])
tol = 1e-6
ends = sorted({r["vertices"][0] for r in base["rods"]} | {r["vertices"][-1] for r in base["rods"]})


def side(axis, high):
    ext = V[:, axis].max() if high else V[:, axis].min()
    return [i for i in range(len(V)) if abs(V[i, axis] - ext) < tol]


def pull(vertices, total):
    loaded = [v for v in vertices if v in ends] or vertices
    return [dict(vertex=int(v), force=list(np.array(total) / len(loaded))) for v in loaded]


left, right, bottom, top = side(0, False), side(0, True), side(1, False), side(1, True)
clamp = lambda vs: [dict(vertex=int(v)) for v in vs]
poses = [
    (dict(name="hang_left", clamped=clamp(left)), (0.0025, 0.0012)),
    (dict(name="hang_right", clamped=clamp(right)), (0.0015, 0.0035)),
    (dict(name="pull_right", clamped=clamp(left), forces=pull(right, [0.3, 0, 0])), (0.0013, 0.002)),
    (dict(name="pull_up", clamped=clamp(bottom), forces=pull(top, [0, 0.3, 0])), (0.0013, 0.002)),
]
scene = dict(base)
scene.pop("design", None)
scene["poses"] = []
with tempfile.TemporaryDirectory() as tmp:
    for pose, radius in poses:
        s = dict(scene)
        s["radius"] = list(radius)
        s["poses"] = [pose]
        p = os.path.join(tmp, "t.json")
        json.dump(s, open(p, "w"))
        subprocess.run([rodmesh, "simulate", p, "-o", p + ".h5", "-q"], check=True)
        with h5py.File(p + ".h5") as f:
            pose = dict(pose)
            pose["target"] = f["poses/%s/positions" % pose["name"]][()].tolist()
        scene["poses"].append(pose)
scene["radius"] = [0.002, 0.002]
scene["design"] = dict(parameters=["radii", "rest_shape"], radius_bounds=[0.001, 0.005], control_points_per_rod=4)
json.dump(scene, open(out, "w"))
print("wrote", out, len(V), "vertices,", len(scene["poses"]), "poses")
