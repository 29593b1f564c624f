#!/usr/bin/python3
"""A sweep: the RMS error the design reaches against the largest radius
allowed, on a small sheet whose targets no design meets exactly, plotted with
matplotlib.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/radius_sweep.py [-o sweep.png]
"""
import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import rodmesh  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("-o", "--output", default="example-output/radius_sweep.png")
parser.add_argument("--time-limit", type=float, default=20)
args = parser.parse_args()

# A cantilevered hex sheet sagging under gravity; the target: the sheet
# held flat, displaced a little upwards (a shape no rod mesh reaches).
base = rodmesh.grid("hex", size=(0.12, 0.12), cells=(2, 2), rod_vertices=6, fix_side="left",
                    gravity=(0, 0, -9.81), design="radii").to_dict()
V = np.asarray(base["vertices"])
target = V.copy()
target[:, 2] = 0.002 * (V[:, 0] - V[:, 0].min()) / np.ptp(V[:, 0])
base["poses"][0]["target"] = target.tolist()

max_radii = [0.0015, 0.002, 0.003, 0.004, 0.006]
rms, initial = [], None
for r_max in max_radii:
    d = dict(base, design=dict(base["design"], radius_bounds=[0.0008, r_max]))
    d["radius"] = min(0.0012, r_max)
    result = rodmesh.optimize(rodmesh.Scene.from_dict(d), time_limit=args.time_limit)
    initial = result.initial_rms_error
    rms.append(result.rms_error)
    print("max radius %.1f mm: RMS %.3f mm (%s)" % (r_max * 1e3, result.rms_error * 1e3, result.status))

plt.figure(figsize=(5, 3.5))
plt.plot(np.array(max_radii) * 1e3, np.array(rms) * 1e3, "o-", label="designed")
plt.axhline(initial * 1e3, color="grey", ls="--", label="initial design")
plt.xlabel("largest radius allowed [mm]")
plt.ylabel("RMS error to target [mm]")
plt.legend()
plt.tight_layout()
plt.savefig(args.output, dpi=120)
print("wrote", args.output)
