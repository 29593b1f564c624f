#!/usr/bin/python3
"""The example design from Python: a rod mesh from the hat surface and two
deformed copies, optimized, saved, exported like `scripts/run-example.sh`.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/design_hat.py [--time-limit S]
"""
import argparse
import os

import rodmesh

here = os.path.dirname(os.path.abspath(__file__))
surfaces = os.path.join(here, os.pardir, "surfaces")
parser = argparse.ArgumentParser()
parser.add_argument("--time-limit", type=float, default=60)
parser.add_argument("-o", "--output", default="example-output/hat_design_py.h5")
args = parser.parse_args()

scene = rodmesh.mesh_surface(
    os.path.join(surfaces, "hat.obj"),
    poses=[os.path.join(surfaces, "hat_front_down.obj"), os.path.join(surfaces, "hat_lean_left.obj")],
    cells=40, fix_box=[-1, -1, -0.01, 1, 1, 0.001])
print(scene)


def progress(info):
    print("iter %4d  %-10s RMS %.4f mm" % (info["iteration"], info["phase"], info["rms_error"] * 1e3))


result = rodmesh.optimize(scene, time_limit=args.time_limit, callback=progress)
print(result)
print("RMS %.4f mm, initial design %.4f mm" % (result.rms_error * 1e3, result.initial_rms_error * 1e3))
os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
result.save(args.output)
print("wrote", args.output, "(rodmesh export %s -o hat.stl for the solid)" % args.output)
