// Hidden-design sheets (needs meshing/grid).
#include "meshing/grid.hh"
#include "model/design_space.hh"
#include "solver/equilibrium.hh"
#include "tests/testutil/design_problems.hh"

#include <gtest/gtest.h>

#include <random>

namespace rodmesh::testutil {

using namespace meshing;

HiddenDesignProblem hiddenDesignSheet(bool radii, bool rest, unsigned seed, int poses) {
  GridOptions g;
  g.width = g.height = 0.06;
  g.cellsX = g.cellsY = 2;
  g.rodVertices = 5;
  g.gravity = Vec3(0, 0, -9.81);
  g.fixSides = {GridSide::Left};
  g.designRadii = radii;
  g.designRestShape = rest;
  g.radiusMin = 0.0008;
  g.radiusMax = 0.004;
  HiddenDesignProblem pr;
  Scene s = makeGridSheet(g).scene;
  std::vector<ClampedVertex> clamps;
  for (const FixedVertex& f : s.poses.at(0).fixed) clamps.push_back({f.vertex});
  const std::vector<int> right = sideVertices(s, GridSide::Right, 1e-9);
  s.poses.clear();
  Pose sag;
  sag.name = "sag";
  sag.clamped = clamps;
  Pose lift = sag;
  lift.name = "lift";
  lift.forces.push_back({right.front(), Vec3(0.0, 0.02, 0.01)});
  s.poses = {sag, lift};
  if (poses >= 3) {
    Pose twist = sag;
    twist.name = "twist";
    twist.forces.push_back({right.back(), Vec3(0.01, -0.01, -0.02)});
    s.poses.push_back(twist);
  }
  s.gravity = Vec3(0, 0, -9.81);
  s.effects.reset();

  // Hidden design: random control values inside the bounds.
  SceneModel model0(s);
  const DesignSpace space(s, model0.effects());
  ControlValues hidden = space.initialControls(s);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  if (radii)
    for (int i = 0; i < hidden.radii.rows(); ++i)
      for (int k = 0; k < 2; ++k) hidden.radii(i, k) = 0.0012 + 0.0014 * U(rng);
  if (rest)
    for (int i = 0; i < hidden.displacement.rows(); ++i) hidden.displacement(i, 2) = 0.003 * (U(rng) - 0.5);
  const Design hd = space.toDesign(hidden);
  Scene h = s;
  h.vertices = hd.restPositions;
  h.radii = hd.radii;
  SceneModel hm(h);
  const SimulationResult sim = simulateAll(hm, Design::fromScene(h), NewtonOptions{});
  EXPECT_TRUE(sim.allConverged);
  for (std::size_t p = 0; p < s.poses.size(); ++p) s.poses[p].target = sim.poses[p].positions;
  for (const Vec2& r : hd.radii) {
    pr.hiddenRadiusMin = std::min(pr.hiddenRadiusMin, r.minCoeff());
    pr.hiddenRadiusMax = std::max(pr.hiddenRadiusMax, r.maxCoeff());
  }
  pr.scene = s;
  pr.hidden = hidden;
  return pr;
}

}  // namespace rodmesh::testutil
