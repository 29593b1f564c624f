// Design-optimization test problems shared by the reduced-space and SAND
// tests.
#pragma once

#include "model/design.hh"
#include "model/design_space.hh"
#include "model/scene.hh"
#include "solver/newton.hh"

namespace rodmesh::testutil {

// Three curved rods meeting at vertex 0, one split at vertex 2 (a two-rod
// connection), a clamp at the far end of rod 1, a pin at rest at the far end
// of rod 2 (it moves with the rest shape), an explicit fixed position on
// rod 3 in the second pose; gravity, anisotropic sections, twist in 3D; two
// poses with different weights; radii and rest shape free, 4 control points
// per rod. `planar`: everything in the xy plane (planar unknowns).
Scene designNetwork(bool planar);

// Sets every pose's target to its equilibrium, solved from rest with the
// default Newton options, under the scene's design with all radii scaled by
// radiusScale (uniform radii stay representable by the control points).
void setScaledRadiiTargets(Scene& s, double radiusScale);


// Radii free within [0.5, 2] mm, 4 control points per rod.
void freeRadii(Scene& s);

// A cantilever of 20 edges over 0.2 m along +x (testutil::cantilever, radius
// 1 mm, E = 1e7 Pa), clamped at x = 0 and bent far by a lateral tip force
// (0, force, 0) N in its one pose "bend"; freeRadii. No targets.
Scene bentCantilever(double force);

// A run whose final design cannot be re-solved from rest
// (solver/design_fallback.hh): bentCantilever(2e-3) with targets from 0.6
// times its radii, and Newton limited to 6 iterations per load step
// (fallbackCaseNewton; `rodmesh simulate --max-iter 6`) for the optimizer and
// the re-solves alike. Warm starts from a nearby design's equilibrium
// converge; from rest, radii of 0.8 times the initial ones and more converge,
// 0.7 and less do not.
Scene fallbackCase();
NewtonOptions fallbackCaseNewton();

// A shallow arch (span 1 m, rise 5 cm, r = 5 mm, pinned ends, solved in its
// plane) under 0.2 N at its crown (vertex 20 of 41), below its limit load
// (0.44 N): loaded from rest it stays up. Its inverted equilibrium under the
// same design and load is stable too. Radii free in [4, 6] mm; targets unset
// (the rest positions).
Scene invertibleArch();
// The arch `s`'s inverted equilibrium under `d` (Newton from the mirrored arch
// at the full load), as a state of `sys`.
PoseState invertedArchState(const Scene& s, const PoseSystem& sys, const Design& d);

// A small hexagonal sheet (meshing/grid, 2 x 2 cells, 0.06 m) clamped along
// its left side; poses: "sag" (gravity), "lift" (right corner pulled and
// lifted) and, with poses = 3, "twist" (the other right corner pulled down
// and back). Targets are the equilibria of a hidden design: random control
// values inside the bounds (radii) and random vertical rest displacements.
// Only in builds with meshing/grid (tests/CMakeLists.txt).
struct HiddenDesignProblem {
  Scene scene;
  double hiddenRadiusMin = 1e9, hiddenRadiusMax = 0;
  ControlValues hidden;  // the hidden design's control values
};
HiddenDesignProblem hiddenDesignSheet(bool radii, bool rest, unsigned seed, int poses = 2);

}  // namespace rodmesh::testutil
