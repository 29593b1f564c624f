// Poses without supports: unbalanced loads have no static equilibrium and are
// reported as such (never as converged); self-balanced loads converge.
#include "meshing/grid.hh"
#include "solver/equilibrium.hh"
#include "tests/testutil/scenes.hh"

#include <gtest/gtest.h>

namespace rodmesh {
namespace {

TEST(Supports, UnbalancedLoadWithoutSupportsIsReportedNotConverged) {
  Scene s = testutil::straightRod(10, 0.1, 0.002, 0.001);
  s.poses[0].forces.push_back({10, Vec3(0, 0.01, 0)});
  SceneModel model(s);
  const SimulationResult r = simulateAll(model, Design::fromScene(s), NewtonOptions{});
  EXPECT_FALSE(r.allConverged);
  EXPECT_FALSE(r.poses[0].report.converged());
  EXPECT_NE(r.poses[0].report.message.find("no static equilibrium"), std::string::npos) << r.poses[0].report.message;
  EXPECT_GT(r.poses[0].report.residualNorm, 0.0);
}

TEST(Supports, SelfBalancedLoadWithoutSupportsConverges) {
  Scene s = testutil::straightRod(10, 0.1, 0.002, 0.001);
  s.poses[0].forces.push_back({0, Vec3(-0.01, 0, 0)});
  s.poses[0].forces.push_back({10, Vec3(0.01, 0, 0)});
  SceneModel model(s);
  const SimulationResult r = simulateAll(model, Design::fromScene(s), NewtonOptions{});
  ASSERT_TRUE(r.allConverged) << r.poses[0].report.message;
  // Axial stretch of a free bar under end forces: F L / (E A).
  const double stretch = r.poses[0].positions[10].x() - r.poses[0].positions[0].x() - 0.1;
  const double exact = 0.01 * 0.1 / (1e7 * 3.14159265358979 * 0.002 * 0.001);
  EXPECT_NEAR(stretch, exact, 1e-6 * exact);
}

// A run that reports convergence satisfies equilibrium at the full load.
TEST(Supports, ConvergedMeansEquilibriumAtFullLoad) {
  Scene s = testutil::straightRod(20, 0.1, 0.002, 0.001);
  s.poses[0].clamped.push_back({0});
  s.poses[0].forces.push_back({20, Vec3(0, 0.3, -0.2)});
  SceneModel model(s);
  const Design d = Design::fromScene(s);
  const SimulationResult r = simulateAll(model, d, NewtonOptions{});
  ASSERT_TRUE(r.allConverged);
  const PoseSystem& sys = model.pose(0);
  Eigen::VectorXd g;
  // The returned state, in its own charts (a solve may re-anchor the
  // reference frames of edges that turned far).
  sys.evaluate(r.poses[0].state, d, &g, nullptr);
  EXPECT_LE(sys.forceResidual(g).norm(), 1e-6 * r.poses[0].report.loadScale);
}

// A rod whose reference normals lie along it (the scene reader refuses such
// normals; a Scene built in code does not pass through it) has no rest
// frame consistent with its normals: its rest frames are undefined (NaN,
// model/energies/rod_math.hh, restFrameOf), and before they were, its rest
// state was out of equilibrium by 39 N. A tip load small against that force
// "added nothing" to it, and the rest state was returned as converged;
// converged means an equilibrium whatever the model, and nothing archived
// is NaN.
TEST(Supports, ARestStateOutOfEquilibriumIsNotReturnedAsConverged) {
  Scene s = testutil::straightRod(40, 0.1, 0.002, 0.001);
  const Vec3 along = Vec3(1, 2, 2) / 3.0;
  for (std::size_t v = 0; v < s.vertices.size(); ++v) s.vertices[v] = s.vertices[v].x() * along;
  s.normals.assign(s.vertices.size(), along);
  s.effects = std::vector<Effect>{Effect::Stretch, Effect::Bend, Effect::Twist};
  s.poses[0].clamped.push_back({0});
  s.poses[0].forces.push_back({40, Vec3(1.7e-3, 8.4e-4, -1.7e-3)});
  SceneModel model(s);
  const Design d = Design::fromScene(s);
  const PoseSystem& sys = model.pose(0);
  Eigen::VectorXd g;
  sys.evaluate(sys.restState(d), d, &g, nullptr);
  const double restResidual = sys.forceResidual(g).norm();
  ASSERT_FALSE(restResidual <= 1.0) << "the rest state is no equilibrium: " << restResidual;
  const SimulationResult r = simulateAll(model, d, NewtonOptions{});
  ASSERT_EQ(r.poses.size(), 1u);
  sys.evaluate(r.poses[0].state, d, &g, nullptr);
  if (r.poses[0].report.converged()) {
    EXPECT_LE(sys.forceResidual(g).norm(), 1e-6) << r.poses[0].report.message;
  }
  EXPECT_NE(r.poses[0].report.message, "no load: rest configuration");
  for (const Vec3& x : r.poses[0].positions) EXPECT_TRUE(x.allFinite()) << r.poses[0].report.message;
}

// A sheet held at two vertices only is hinged about the line through them:
// its rigid rotation about that line has no stiffness. Unloaded, its rest
// state is converged and stable (a zero-stiffness mode is no negative
// curvature: the same classification of pivots as Newton's), not
// "converged" with stable = 0, as the rotation's eigenvalue at -8e-15 N/m
// used to be counted.
TEST(Supports, AHingedSheetAtRestIsStableWithAZeroMode) {
  meshing::GridOptions g;
  g.width = g.height = 0.06;
  g.cellsX = g.cellsY = 2;
  g.rodVertices = 3;
  g.designRadii = g.designRestShape = false;
  Scene s = meshing::makeGridSheet(g).scene;
  s.design = DesignSpec{};
  s.poses.assign(1, Pose{});
  s.poses[0].name = "hinged";
  s.poses[0].fixed = {{0, std::nullopt}, {static_cast<int>(s.vertices.size()) - 1, std::nullopt}};
  // In 3D (a flat sheet would be solved in plane, where nothing rotates
  // about the hinge).
  s.effects = std::vector<Effect>{Effect::Stretch, Effect::Bend, Effect::Twist, Effect::Connections};
  SceneModel model(s);
  const SimulationResult r = simulateAll(model, Design::fromScene(s), NewtonOptions{});
  ASSERT_TRUE(r.allConverged) << r.poses[0].report.message;
  ASSERT_TRUE(r.poses[0].stable.has_value());
  EXPECT_TRUE(*r.poses[0].stable);
  ASSERT_TRUE(r.poses[0].smallestEigenvalue.has_value());
  EXPECT_LT(std::abs(*r.poses[0].smallestEigenvalue), 1e-9) << "the hinge has no stiffness";
}

}  // namespace
}  // namespace rodmesh
