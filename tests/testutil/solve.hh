// Solving a scene's first pose through the production path (SceneModel +
// simulateAll), shared by the validation and behaviour tests.
#pragma once

#include "solver/equilibrium.hh"

#include <string>
#include <vector>

namespace rodmesh::testutil {

struct Solved {
  std::vector<Vec3> x;
  Eigen::VectorXd theta;  // per edge: material twist from the transported rest frame
  NewtonReport report;
  int dofs = 0;
  EffectSet effects;
};

// Solves the first pose of `s` with the given relative force-residual tolerance.
Solved solve(const Scene& s, double tolerance = NewtonOptions{}.tolerance);

// "%.3e", for test properties (--gtest_output=xml).
std::string sci(double v);

}  // namespace rodmesh::testutil
