#!/usr/bin/python3
"""The model's Hessian in scipy: the stiffness of a pose at its equilibrium,
its softest modes (eigsh) and a design sensitivity by spsolve.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/hessian_scipy.py
"""
import os

import numpy as np
import scipy.sparse.linalg as sla

import rodmesh

here = os.path.dirname(os.path.abspath(__file__))
scene = rodmesh.Scene.load(os.path.join(here, os.pardir, "cantilever.json"))
model = rodmesh.PoseModel(scene, pose="tip_load")
print(model)

u = model.rest_state()
H = model.hessian(u)  # scipy.sparse, both triangles
print("H at rest: %d x %d, %d non-zeros, symmetric: %s" % (H.shape[0], H.shape[1], H.nnz, abs(H - H.T).max() == 0))
print("|g| at rest %.3e N" % np.linalg.norm(model.gradient(u)))

# The equilibrium the simulator finds, in the model's unknowns, and its
# three softest modes.
result = rodmesh.simulate(scene)
x, twist = result.poses["tip_load"].positions, result.poses["tip_load"].twist
info = model.dof_info
for i, kind in enumerate(info["kind"]):
    u[i] = x[info["vertex"][i], info["coordinate"][i]] if kind == "position" else twist[info["edge"][i]]
print("|g| at the equilibrium %.3e" % np.linalg.norm(model.gradient(u)))
vals = sla.eigsh(model.hessian(u), k=3, sigma=0, which="LM", return_eigenvectors=False)
print("softest stiffnesses:", np.sort(vals))

# Design sensitivity: how the equilibrium moves when every radius grows by
# 1% (du = -H^-1 dF/dp dp).
p = model.design_vector()
dp = np.zeros_like(p)
nv = scene.n_vertices
dp[3 * nv:] = 0.01 * p[3 * nv:]
J = model.design_jacobian(u)
du = sla.spsolve(model.hessian(u).tocsc(), -(J @ dp))
tip = [i for i, v in enumerate(info["vertex"]) if v == 10 and info["coordinate"][i] == 2][0]
print("tip deflection change for radii +1%%: %.3e m" % du[tip])
