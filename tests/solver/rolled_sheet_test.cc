// The loading path of a sheet rolled through a large angle (docs/model.md,
// "The loading path"): a hex sheet held along its left side whose right side
// (the handle) is carried onto a cylinder, 120 degrees round, as a
// prescribed displacement. The path is smooth and stable all the way, but
// along it the rods turn far: Newton's linear step from one equilibrium
// stretches them to second order, and their axial stiffness throws the
// corrector far from that tangent prediction. The continuation predicts
// with the secant through its last two equilibria instead, and takes a few
// load steps where it took the smallest step nearly all the way (820 load
// steps for this sheet; 1434 for the roll pose of benchmarks/other_model's
// shape_small, a sheet like it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "meshing/grid.hh"
#include "model/scene_model.hh"
#include "solver/newton.hh"
#include "io/scene_reader.hh"
#include "tests/testutil/solve.hh"

namespace rodmesh {
namespace {

// A 100 mm hex sheet of cells x cells cells, rods of `rodVertices`
// vertices, held along its left side; no design.
Scene heldSheet(int cells, int rodVertices) {
  meshing::GridOptions g;
  g.width = g.height = 0.1;
  g.cellsX = g.cellsY = cells;
  g.rodVertices = rodVertices;
  g.designRadii = g.designRestShape = false;
  g.fixSides = {meshing::GridSide::Left};
  Scene s = meshing::makeGridSheet(g).scene;
  s.design = DesignSpec{};
  return s;
}

Scene rolledSheet(double degrees) {
  Scene s = heldSheet(3, 4);
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

// The first pose's vertex positions at the full load reached in `steps`
// equal load steps, Newton from each equilibrium to the next (a natural
// continuation without step control: the reference path).
std::vector<Vec3> equalSteps(const Scene& s, int steps) {
  const SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  const Design d = Design::fromScene(s);
  const double scale = loadScale(sys, d);
  PoseState walk = sys.restState(d);
  for (int k = 1; k <= steps; ++k) {
    walk.loadFactor = static_cast<double>(k) / steps;
    const NewtonReport rk = newtonSolve(sys, d, walk, scale, 1e-10, NewtonOptions{});
    EXPECT_TRUE(rk.converged()) << "step " << k << ": " << rk.message;
    if (!rk.converged()) break;
  }
  return sys.positions(walk, d);
}

double largestGap(const std::vector<Vec3>& x, const std::vector<Vec3>& y) {
  EXPECT_EQ(x.size(), y.size());
  double gap = 0.0;
  for (std::size_t v = 0; v < x.size() && v < y.size(); ++v) gap = std::max(gap, (x[v] - y[v]).norm());
  return gap;
}

TEST(RolledSheet, TheLoadingPathTakesAFewStepsAndIsTheOneFollowedInSmallSteps) {
  const Scene s = rolledSheet(120.0);
  // Along the loading path, as `rodmesh simulate` solves it.
  const testutil::Solved solved = testutil::solve(s);
  const NewtonReport& r = solved.report;
  ASSERT_TRUE(r.converged()) << r.message;
  EXPECT_EQ(r.loadFactor, 1.0);
  EXPECT_TRUE(r.criticalPoints.empty()) << r.message;
  EXPECT_LE(r.loadSteps, 40) << "a smooth path in a few steps";

  EXPECT_GT(largestGap(solved.x, s.vertices), 0.05) << "the handle went round";
  // The same equilibrium as 200 equal load steps reach.
  EXPECT_LT(largestGap(solved.x, equalSteps(s, 200)), 1e-6)
      << "the loading path's equilibrium is the one reached in small steps";
}

// A rod (100 mm, r = 2 x 1 mm) held at one end whose other end (its last
// two vertices) is carried round onto a 120-degree arc, in plane. Early on
// the chord motion compresses it (the smallest stiffness eigenvalue dips
// from 3.9 to 0.4 N/m in the first 0.3% of the load, where it bends away);
// after that the end turns it smoothly. Every load step longer than the
// smallest then started at negative curvature (the held vertices moved, the
// rods next to them compressed), and each smallest step was reported as a
// critical point: 26 of them, up to 2.4% of the load, each "jumping" about
// as far as the held end moved, the first at load factor 0. A smallest step
// that lands where the last step was heading is a step of the path, not a
// jump; nor is the first step from a stable rest state.
TEST(RolledSheet, ARodWhoseEndIsCarriedRoundReportsNoJumpsAlongItsSmoothPath) {
  constexpr int n = 11;
  constexpr double L = 0.1;
  const double angle = 2.0 * M_PI / 3.0, R = L / angle;
  auto rolled = [&](double arc) { return Vec3(R * std::sin(arc / R), 0.0, R * (1.0 - std::cos(arc / R))); };
  Scene s;
  s.material = Material{3.2e7, 0.48, 1200.0};
  Rod rod;
  for (int i = 0; i < n; ++i) {
    s.vertices.emplace_back(L * i / (n - 1), 0.0, 0.0);
    s.normals.emplace_back(0.0, 0.0, 1.0);
    s.radii.emplace_back(0.002, 0.001);
    rod.vertices.push_back(i);
  }
  s.rods.push_back(rod);
  Pose pose;
  pose.name = "roll";
  pose.fixed = {{0, std::nullopt}, {1, std::nullopt}, {n - 2, rolled(L * (n - 2) / (n - 1))}, {n - 1, rolled(L)}};
  s.poses.push_back(pose);
  // Along the loading path, as `rodmesh simulate` solves it.
  const testutil::Solved solved = testutil::solve(s);
  const NewtonReport& r = solved.report;
  ASSERT_TRUE(r.converged()) << r.message;
  EXPECT_LE(r.criticalPoints.size(), 2u) << r.message;
  for (const CriticalPoint& cp : r.criticalPoints) {
    EXPECT_LT(cp.loadFactor, 0.005) << r.message;
    EXPECT_GT(cp.loadFactor, 0.0) << "the rest state is stable: no jump at the first load step; " << r.message;
  }

  // The same equilibrium as 1000 equal load steps reach.
  EXPECT_LT(largestGap(solved.x, equalSteps(s, 1000)), 1e-6);
}

// A finer, softer sheet like it (rods of 8 vertices, E = 32 MPa, under its own
// weight) whose handle is lifted by 20 mm. Newton's first step from rest at
// the lifted handle stretches the edges next to it by the square of the
// lift over their length: it meets negative curvature at once down to small
// load factors, and the path doubled back from there to the full load (15
// load steps, 60 Newton iterations). Predicted by the path's tangent at
// rest (the stiffness there against the rate at which the handle's motion
// and the weight load the sheet), the full load is one step whose corrector
// converges like Newton's method (4 iterations).
TEST(RolledSheet, ALiftedHandleIsOneStepFromTheTangentAtRest) {
  Scene s = heldSheet(6, 8);
  for (const int v : meshing::sideVertices(s, meshing::GridSide::Right, 1e-9))
    s.poses[0].fixed.push_back({v, s.vertices[static_cast<std::size_t>(v)] + Vec3(0.0, 0.0, 0.02)});
  s.gravity = Vec3(0.0, 0.0, -9.81);
  s.material = Material{3.2e7, 0.48, 1200.0};
  s.effects.reset();
  const testutil::Solved solved = testutil::solve(s);
  const NewtonReport& r = solved.report;
  ASSERT_TRUE(r.converged()) << r.message;
  EXPECT_TRUE(r.criticalPoints.empty()) << r.message;
  EXPECT_EQ(r.loadSteps, 1) << r.message;
  EXPECT_LE(r.iterations, 6) << r.message;
  EXPECT_GT(largestGap(solved.x, s.vertices), 0.015) << "the handle went up";
  EXPECT_LT(largestGap(solved.x, equalSteps(s, 50)), 1e-6)
      << "the loading path's equilibrium is the one reached in small steps";
}

// A designed sheet (benchmarks/other_model's shape_small, an archived SAND
// design) whose handle is carried onto a helicoid: the prescribed motion
// twists the handle about the sheet's axis. Newton from rest at the full
// load took 15 iterations and landed within pathDeviation of its first step,
// so the whole load was accepted as one step of the path: an equilibrium
// 2.6 mm from the one that 100 and 400 equal load steps reach. Its corrector
// was not converging like Newton's method (the full step refused by the line
// search, the residual rising); started from the path's tangent and stopped
// there, the step is refused and the continuation follows the path.
TEST(RolledSheet, AHandleCarriedOntoAHelicoidIsFollowedToTheEqualStepsEquilibrium) {
  const Scene s = readSceneFile(std::string(RODMESH_SOURCE_DIR) + "/tests/solver/data/helicoid_sheet.json");
  ASSERT_EQ(s.poses.size(), 1u);
  const testutil::Solved solved = testutil::solve(s);
  const NewtonReport& r = solved.report;
  ASSERT_TRUE(r.converged()) << r.message;
  EXPECT_GT(r.loadSteps, 1) << r.message;
  EXPECT_LT(largestGap(solved.x, equalSteps(s, 100)), 1e-6)
      << "the loading path's equilibrium is the one reached in small steps";
}

// A designed sheet (benchmarks/other_model's shell_large, a SAND design
// whose rest shape is curved) whose handle is twisted: along the path every
// rod near the handle turns its material frame with it, so the twist
// unknowns change as much as the positions. A secant prediction that moved
// the positions and left the twists where they were started every step
// longer than the last at negative curvature, so the steps could not grow
// (543 load steps); predicted with the twists' own secant (their charts were
// not re-anchored along the step), the path takes a few dozen.
TEST(RolledSheet, ATwistedHandlesPathPredictsTheTwistsToo) {
  const Scene s = readSceneFile(std::string(RODMESH_SOURCE_DIR) + "/tests/solver/data/twisted_design_sheet.json");
  ASSERT_EQ(s.poses.size(), 1u);
  const testutil::Solved solved = testutil::solve(s);
  const NewtonReport& r = solved.report;
  ASSERT_TRUE(r.converged()) << r.message;
  EXPECT_TRUE(r.criticalPoints.empty()) << r.message;
  EXPECT_LE(r.loadSteps, 100) << r.message;
  EXPECT_LT(largestGap(solved.x, equalSteps(s, 200)), 1e-6)
      << "the loading path's equilibrium is the one reached in small steps";
}

}  // namespace
}  // namespace rodmesh
