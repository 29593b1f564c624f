// The loading path of a sheet rolled through a large angle (docs/model.md,
// "The loading path"): a hex sheet held along its left side whose right side
// (the handle) is carried onto a cylinder, 120 degrees round, as a
// prescribed displacement. The path is smooth and stable all the way, but
// along it the rods turn far: Newton's linear step from one equilibrium
// stretches them to second order, and their axial stiffness throws the
// corrector far from that tangent prediction. The continuation predicts
// with the secant through its last two equilibria instead, and takes a few
// load steps where it took the smallest step all the way (1434 steps on
// benchmarks/other_model's shape_small roll pose, the sheet of this test
// with its targets).
#include <gtest/gtest.h>

#include <cmath>

#include "meshing/grid.hh"
#include "model/scene_model.hh"
#include "solver/newton.hh"

namespace rodmesh {
namespace {

Scene rolledSheet(double degrees) {
  meshing::GridOptions g;
  g.width = g.height = 0.1;
  g.cellsX = g.cellsY = 3;
  g.rodVertices = 4;
  g.designRadii = g.designRestShape = false;
  g.fixSides = {meshing::GridSide::Left};
  Scene s = meshing::makeGridSheet(g).scene;
  s.design = DesignSpec{};
  double x0 = s.vertices.front().x(), x1 = x0;
  for (const Vec3& v : s.vertices) {
    x0 = std::min(x0, v.x());
    x1 = std::max(x1, v.x());
  }
  // Rolled onto a cylinder about an axis along y, from the held side on:
  // arc length along the sheet is kept.
  const double angle = degrees * M_PI / 180.0, R = (x1 - x0) / angle;
  for (const int v : meshing::sideVertices(s, meshing::GridSide::Right, 1e-9)) {
    const Vec3& p = s.vertices[static_cast<std::size_t>(v)];
    const double t = (p.x() - x0) / R;
    s.poses[0].fixed.push_back({v, Vec3(x0 + R * std::sin(t), p.y(), p.z() + R * (1.0 - std::cos(t)))});
  }
  s.effects.reset();
  return s;
}

TEST(RolledSheet, TheLoadingPathTakesAFewStepsAndIsTheOneFollowedInSmallSteps) {
  const Scene s = rolledSheet(120.0);
  const SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  const Design d = Design::fromScene(s);

  PoseState state = sys.restState(d);
  const NewtonReport r = solveEquilibrium(sys, d, state, NewtonOptions{});
  ASSERT_TRUE(r.converged()) << r.message;
  EXPECT_EQ(state.loadFactor, 1.0);
  EXPECT_TRUE(r.criticalPoints.empty()) << r.message;
  EXPECT_LE(r.loadSteps, 40) << "a smooth path in a few steps";

  // The same path followed in 200 equal load steps, Newton from each
  // equilibrium to the next: the same equilibrium at the full load.
  const double scale = loadScale(sys, d);
  PoseState walk = sys.restState(d);
  const int steps = 200;
  for (int k = 1; k <= steps; ++k) {
    walk.loadFactor = static_cast<double>(k) / steps;
    const NewtonReport rk = newtonSolve(sys, d, walk, scale, 1e-10, NewtonOptions{});
    ASSERT_TRUE(rk.converged()) << "step " << k << ": " << rk.message;
  }
  const std::vector<Vec3> x = sys.positions(state, d), y = sys.positions(walk, d);
  double gap = 0.0, moved = 0.0;
  for (std::size_t v = 0; v < x.size(); ++v) {
    gap = std::max(gap, (x[v] - y[v]).norm());
    moved = std::max(moved, (x[v] - s.vertices[v]).norm());
  }
  EXPECT_GT(moved, 0.05) << "the handle went round";
  EXPECT_LT(gap, 1e-6) << "the loading path's equilibrium is the one reached in small steps";
}

}  // namespace
}  // namespace rodmesh
