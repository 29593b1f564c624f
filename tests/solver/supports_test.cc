// Poses without supports: unbalanced loads have no static equilibrium and are
// reported as such (never as converged); self-balanced loads converge.
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

}  // namespace
}  // namespace rodmesh
