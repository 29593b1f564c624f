#!/usr/bin/python3
"""A sweep: the RMS error the design reaches against the largest radius
allowed, on a small sheet, plotted with matplotlib.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/radius_sweep.py [-o sweep.png]
"""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import rodmesh  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("-o", "--output", default="example-output/radius_sweep.png")
parser.add_argument("--time-limit", type=float, default=30)
args = parser.parse_args()

# A small sheet whose targets come from a hidden design (radii only, bounds
# [0.8, 4] mm): with a smaller largest radius the targets cannot be met.
here = os.path.dirname(os.path.abspath(__file__))
base = rodmesh.Scene.load(os.path.join(here, os.pardir, os.pardir, "tests", "cli", "optimize_small.json")).to_dict()
lo = base["design"]["radius_bounds"][0]

max_radii = [0.0012, 0.0016, 0.002, 0.0025, 0.003, 0.004]
rms, initial = [], []
for r_max in max_radii:
    d = dict(base, design=dict(base["design"], radius_bounds=[lo, r_max]))
    # the initial radii must lie within the bounds
    key = "radii" if "radii" in d else "radius"
    d[key] = np.clip(np.asarray(d[key]), lo, r_max).tolist()
    result = rodmesh.optimize(rodmesh.Scene.from_dict(d), time_limit=args.time_limit)
    initial.append(result.initial_rms_error)
    rms.append(result.rms_error)
    print("max radius %.1f mm: RMS %.4f mm (initial design %.4f mm, %s)"
          % (r_max * 1e3, result.rms_error * 1e3, result.initial_rms_error * 1e3, result.status))

plt.figure(figsize=(5, 3.5))
plt.plot(np.array(max_radii) * 1e3, np.array(rms) * 1e3, "o-", label="designed")
plt.plot(np.array(max_radii) * 1e3, np.array(initial) * 1e3, "s--", color="grey", label="initial design")
plt.xlabel("largest radius allowed [mm]")
plt.ylabel("RMS error to target [mm]")
plt.legend()
plt.tight_layout()
plt.savefig(args.output, dpi=120)
print("wrote", args.output)
