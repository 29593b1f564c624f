// Design-optimization test problems shared by the reduced-space and SAND
// tests.
#pragma once

#include "model/scene.hh"

namespace rodmesh::testutil {

// Three curved rods meeting at vertex 0, one split at vertex 2 (a two-rod
// connection), a clamp at the far end of rod 1, a pin at rest at the far end
// of rod 2 (it moves with the rest shape), an explicit fixed position on
// rod 3 in the second pose; gravity, anisotropic sections, twist in 3D; two
// poses with different weights; radii and rest shape free, 4 control points
// per rod. `planar`: everything in the xy plane (planar unknowns).
Scene designNetwork(bool planar);

// A small hexagonal sheet (meshing/grid, 2 x 2 cells, 0.06 m) clamped along
// its left side; poses: "sag" (gravity), "lift" (right corner pulled and
// lifted) and, with poses = 3, "twist" (the other right corner pulled down
// and back). Targets are the equilibria of a hidden design: random control
// values inside the bounds (radii) and random vertical rest displacements.
// Only in builds with meshing/grid (tests/CMakeLists.txt).
struct HiddenDesignProblem {
  Scene scene;
  double hiddenRadiusMin = 1e9, hiddenRadiusMax = 0;
};
HiddenDesignProblem hiddenDesignSheet(bool radii, bool rest, unsigned seed, int poses = 2);

}  // namespace rodmesh::testutil
