// Scene builders shared by the tests (straight and curved rods, cantilevers).
#pragma once

#include "model/scene.hh"

namespace rodmesh::testutil {

// A straight rod along +x from the origin, `edges` edges over `length`,
// uniform radii, one pose with no boundary conditions. Material: E = 1e7 Pa,
// nu = 0.4, rho = 1000 kg/m^3 unless changed by the caller.
Scene straightRod(int edges, double length, double rt, double rn);

// A cantilever: straight rod along +x from the origin (`edges` equal edges
// over `length`, uniform radii [rt, rn]), clamped at vertex 0 (the root), free
// at vertex `edges` (the tip). Every vertex gets the explicit reference
// normal `normal` (Scene::normals, perpendicular to x), so the r_n semi-axis
// lies along `normal` and the r_t semi-axis along normal x x.
// One pose named "pose0" with only the clamp; loads are added by the caller.
// Material as in straightRod.
Scene cantilever(int edges, double length, double rt, double rn, const Vec3& normal);

// A circular arc of `radius` in the xy plane, centred at the origin, from
// angle 0 to `angle` [rad] (counter-clockwise), `edges` equal edges, uniform
// radii, reference normals +z, clamped at vertex 0. One pose "pose0" with only
// the clamp. Material as in straightRod.
Scene clampedArc(int edges, double radius, double angle, double rt, double rn);

// Index of the last vertex of the first rod (the free tip of the builders above).
int tipVertex(const Scene& s);

}  // namespace rodmesh::testutil
