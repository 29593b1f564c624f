// Held vertices on the loading path (PoseSystem::positions at a load factor
// L): a handle (vertices held at explicit positions, joined by edges) whose
// prescribed positions are a rigid motion of its rest positions turns
// rigidly with L, so that it keeps its length on the way and a half turn
// does not make its vertices meet; any other prescribed motion goes on
// straight lines. Both reach the prescribed positions exactly at L = 1 and
// start at rest at L = 0, and the path depends on the design's rest
// positions and the prescribed ones only.
#include "model/design.hh"
#include "model/pose_system.hh"
#include "model/scene_model.hh"
#include "tests/testutil/scenes.hh"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace rodmesh {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A straight rod of 6 edges along x, clamped at vertex 0, its last two
// vertices (5, 6: the handle) fixed at `rotation` of their rest positions
// about their midpoint, then moved by `shift`; `stretch` scales the
// handle's image about its midpoint (1: rigid).
Scene rodWithHandle(const Eigen::AngleAxisd& rotation, const Vec3& shift, double stretch = 1.0) {
  Scene s = testutil::straightRod(6, 0.12, 0.001, 0.001);
  Pose p;
  p.name = "turn";
  p.clamped.push_back({0});
  const Vec3 mid = 0.5 * (s.vertices[5] + s.vertices[6]);
  for (int v : {5, 6}) p.fixed.push_back({v, Vec3(mid + shift + stretch * (rotation * (s.vertices[v] - mid)))});
  s.poses = {p};
  return s;
}

std::vector<Vec3> heldAt(const PoseSystem& sys, const Design& d, double loadFactor) {
  PoseState st = sys.restState(d);
  st.loadFactor = loadFactor;
  return sys.positions(st, d);
}

// A turn out of the rod's plane (about y): a 3D scene, a straight handle.
TEST(HandleMotion, ARigidlyMovedHandleTurnsRigidlyOnTheWay) {
  const double angle = 150.0 * kPi / 180.0;
  const Eigen::AngleAxisd turn(angle, Vec3::UnitY());
  const Vec3 shift(-0.01, 0.02, 0.005);
  const Scene s = rodWithHandle(turn, shift);
  const SceneModel model(s);
  ASSERT_FALSE(model.effects().planar);
  const PoseSystem& sys = model.pose(0);
  const Design d = Design::fromScene(s);
  const double rest = (s.vertices[6] - s.vertices[5]).norm();
  const Vec3 mid = 0.5 * (s.vertices[5] + s.vertices[6]);
  for (const double L : {0.0, 0.25, 0.5, 0.75, 1.0}) {
    const std::vector<Vec3> x = heldAt(sys, d, L);
    EXPECT_NEAR((x[6] - x[5]).norm(), rest, 1e-15) << "length at L = " << L;
    EXPECT_LT((0.5 * (x[5] + x[6]) - (mid + L * shift)).norm(), 1e-15) << "centre at L = " << L;
    const Vec3 expected = Eigen::AngleAxisd(L * angle, Vec3::UnitY()) * (s.vertices[6] - s.vertices[5]);
    EXPECT_LT((x[6] - x[5] - expected).norm(), 1e-15) << "direction at L = " << L;
  }
  const std::vector<Vec3> end = heldAt(sys, d, 1.0);
  for (const FixedVertex& f : s.poses[0].fixed) EXPECT_LT((end[f.vertex] - *f.position).norm(), 1e-15);
  const std::vector<Vec3> start = heldAt(sys, d, 0.0);
  for (const FixedVertex& f : s.poses[0].fixed) EXPECT_EQ(start[f.vertex], s.vertices[f.vertex]);
}

// A half turn in the scene's plane: straight lines would make the handle's
// two vertices meet at L = 1/2.
TEST(HandleMotion, AHalfTurnInPlaneKeepsTheHandlesLength) {
  const Scene s = rodWithHandle(Eigen::AngleAxisd(kPi, Vec3::UnitZ()), Vec3(0.0, 0.03, 0.0));
  const SceneModel model(s);
  ASSERT_TRUE(model.effects().planar);
  const PoseSystem& sys = model.pose(0);
  const Design d = Design::fromScene(s);
  const double rest = (s.vertices[6] - s.vertices[5]).norm();
  for (const double L : {0.25, 0.5, 0.75}) {
    const std::vector<Vec3> x = heldAt(sys, d, L);
    EXPECT_NEAR((x[6] - x[5]).norm(), rest, 1e-15) << "L = " << L;
    EXPECT_NEAR(x[5].z(), s.vertices[5].z(), 1e-15) << "in the plane, L = " << L;
  }
  const std::vector<Vec3> end = heldAt(sys, d, 1.0);
  for (const FixedVertex& f : s.poses[0].fixed) EXPECT_LT((end[f.vertex] - *f.position).norm(), 1e-15);
}

// A handle stretched by 30% on top of a quarter turn is no rigid motion:
// its vertices go on straight lines, as before.
TEST(HandleMotion, ANonRigidMotionGoesOnStraightLines) {
  const Scene s = rodWithHandle(Eigen::AngleAxisd(0.5 * kPi, Vec3::UnitY()), Vec3::Zero(), 1.3);
  const SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  const Design d = Design::fromScene(s);
  const std::vector<Vec3> half = heldAt(sys, d, 0.5);
  for (const FixedVertex& f : s.poses[0].fixed)
    EXPECT_LT((half[f.vertex] - 0.5 * (s.vertices[f.vertex] + *f.position)).norm(), 1e-15);
}

// The path depends on the design's rest positions and the prescribed ones
// only: the scene made of a design (its rest positions as the scene's, as
// one re-simulates an archive) puts the held vertices where the design
// does at every load factor. (A path built from the scene's own rest
// positions took the archived twisted strip of benchmarks/sweep's set B to
// another equilibrium, 30 mm away.)
TEST(HandleMotion, TheSceneOfADesignFollowsTheDesignsPath) {
  const Scene s = rodWithHandle(Eigen::AngleAxisd(2.0, Vec3(0.3, 1.0, 0.2).normalized()), Vec3(0.0, 0.01, 0.02));
  const SceneModel model(s);
  Design moved = Design::fromScene(s);
  moved.restPositions[5] += Vec3(1e-3, -2e-3, 5e-4);
  moved.restPositions[6] += Vec3(-2e-3, 1e-3, 3e-3);
  moved.restPositions[3] += Vec3(0.0, 1e-3, 0.0);
  const Scene at = sceneOfDesign(s, moved);
  const SceneModel atModel(at);
  const Design same = Design::fromScene(at);
  for (const double L : {0.0, 0.3, 0.5, 0.8, 1.0}) {
    const std::vector<Vec3> a = heldAt(model.pose(0), moved, L), b = heldAt(atModel.pose(0), same, L);
    for (int v : {0, 5, 6}) EXPECT_EQ(a[v], b[v]) << "vertex " << v << ", L = " << L;
  }
}

// Where the design derivatives are taken, at rest and at the full load,
// the designed rest position of a held vertex enters as (1 - L) times
// itself (PoseSystem::heldDesignCoefficient).
TEST(HandleMotion, AtRestAndAtTheFullLoadTheRestPositionEntersWithOneMinusTheLoadFactor) {
  const Scene s = rodWithHandle(Eigen::AngleAxisd(2.0, Vec3(0.3, 1.0, 0.2).normalized()), Vec3(0.0, 0.01, 0.02));
  const SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  const Design d = Design::fromScene(s);
  Design moved = d;
  const Vec3 delta(1e-3, -2e-3, 5e-4);
  moved.restPositions[6] += delta;
  for (const double L : {0.0, 1.0}) {
    const Vec3 change = heldAt(sys, moved, L)[6] - heldAt(sys, d, L)[6];
    EXPECT_LT((change - (1.0 - L) * delta).norm(), 1e-15) << "L = " << L;
    EXPECT_DOUBLE_EQ(sys.heldDesignCoefficient(6, L), 1.0 - L);
  }
}

}  // namespace
}  // namespace rodmesh
