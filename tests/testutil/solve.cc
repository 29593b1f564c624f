#include "tests/testutil/solve.hh"

#include <cstdio>

namespace rodmesh::testutil {

Solved solve(const Scene& s, double tolerance) {
  SceneModel model(s);
  const Design design = Design::fromScene(s);
  NewtonOptions options;
  options.tolerance = tolerance;
  SimulationResult r = simulateAll(model, design, options);
  Solved out;
  out.x = r.poses[0].positions;
  out.theta = r.poses[0].twist;
  out.report = r.poses[0].report;
  out.dofs = model.pose(0).numDofs();
  out.effects = model.effects();
  return out;
}

std::string sci(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3e", v);
  return buf;
}

}  // namespace rodmesh::testutil
