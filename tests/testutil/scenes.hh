// Scene builders shared by the tests (straight and curved rods, cantilevers).
#pragma once

#include "model/scene.hh"

namespace rodmesh::testutil {

// A straight rod along +x from the origin, `edges` edges over `length`,
// uniform radii, one pose with no boundary conditions. Material: E = 1e7 Pa,
// nu = 0.4, rho = 1000 kg/m^3 unless changed by the caller.
Scene straightRod(int edges, double length, double rt, double rn);

}  // namespace rodmesh::testutil
