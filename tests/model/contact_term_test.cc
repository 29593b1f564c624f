// The example term of docs/model.md "Adding an energy term", the soft contact
// penalty (model/terms/contact.hh), against closed forms: its energy and
// force from the formula of docs/formats.md, and a cantilever pressed onto a
// held vertex, whose tip comes to rest where the beam's linear response
// balances the load less the contact's repulsion. (Its Taylor tests are the
// "contact" cases of derivatives_test.cc.)
#include "model/pose_system.hh"
#include "model/scene_model.hh"
#include "solver/newton.hh"
#include "tests/testutil/scenes.hh"

#include <gtest/gtest.h>

#include <cmath>

namespace rodmesh {
namespace {

constexpr double kLength = 0.1, kRadius = 1e-3;
constexpr int kEdges = 20;

// A cantilever along +x (clamped at 0, tip at kEdges), a short held rod
// below the tip (its first vertex `gap` under the tip), the tip loaded by
// `force` along -z, and a contact between the tip and that vertex.
Scene pressedCantilever(double gap, double force, double distance, double stiffness) {
  Scene s = testutil::cantileverOverHeldRod(kEdges, kLength, kRadius, gap);
  const int tip = kEdges, below = kEdges + 1;
  Pose& p = s.poses.at(0);
  p.forces.push_back({tip, Vec3(0.0, 0.0, -force)});
  if (stiffness > 0) p.contacts.push_back({tip, below, distance, stiffness});
  return s;
}

TEST(ContactTerm, EnergyAndForceAreTheClosedForm) {
  const double d = 3e-3, k = 2e-4, gap = 2e-3;
  const Scene s = pressedCantilever(gap, 0.0, d, k);
  const SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  const Design design = Design::fromScene(s);
  const int contact = PoseSystem::termKindIndex("contact");
  ASSERT_GE(contact, 0);
  ASSERT_EQ(sys.termCount(contact), 1);
  // At rest the tip is `gap` above the held vertex: E = k d/3 (1 - r/d)^3,
  // and the force on the tip is k (1 - r/d)^2 upward (-dE/dz).
  const PoseState rest = sys.restState(design);
  Eigen::VectorXd g;
  const double E = sys.evaluate(rest, design, &g, nullptr, PoseSystem::Terms::only(contact));
  const double t = 1.0 - gap / d;
  EXPECT_NEAR(E, k * d / 3.0 * t * t * t, 1e-15);
  const int tipDof = sys.vertexDof()[kEdges];
  ASSERT_GE(tipDof, 0);
  // The scene lies in the plane y = 0: planar unknowns, the gradient in
  // plane coordinates.
  ASSERT_EQ(sys.dofsPerVertex(), 2);
  const Vec3 grad = sys.effects().planeBasis * g.segment<2>(tipDof);
  EXPECT_NEAR(-grad.z(), k * t * t, 1e-12);
  EXPECT_NEAR(grad.x(), 0.0, 1e-15);
  EXPECT_NEAR(grad.norm(), g.norm(), 1e-15);  // no other unknown is touched
  // Beyond the distance it is nothing.
  const Scene far = pressedCantilever(1.5 * d, 0.0, d, k);
  const SceneModel farModel(far);
  const PoseSystem& fs = farModel.pose(0);
  const Design farDesign = Design::fromScene(far);
  EXPECT_EQ(fs.evaluate(fs.restState(farDesign), farDesign, &g, nullptr, PoseSystem::Terms::only(contact)), 0.0);
  EXPECT_EQ(g.norm(), 0.0);
}

// Tip deflection delta of the pressed cantilever, solved along the loading path.
double tipDeflection(double gap, double force, double distance, double stiffness) {
  const Scene s = pressedCantilever(gap, force, distance, stiffness);
  const SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  const Design design = Design::fromScene(s);
  PoseState state = sys.restState(design);
  const NewtonReport r = solveEquilibrium(sys, design, state, NewtonOptions{});
  EXPECT_TRUE(r.converged()) << r.message;
  return -sys.positions(state, design)[kEdges].z();
}

TEST(ContactTerm, PressedCantileverRestsWhereBeamAndContactBalance) {
  const double E = 1e7, I = M_PI * std::pow(kRadius, 4) / 4.0;
  const double K = 3.0 * E * I / std::pow(kLength, 3);  // tip stiffness of the linear beam
  const double F = 1e-4, gap = 4e-3, d = 3e-3, k = 2e-4;
  // Without contact the tip goes down F/K (4.2 mm), past the held vertex's
  // height less the distance.
  const double free = tipDeflection(gap, F, d, 0.0);
  EXPECT_NEAR(free, F / K, 0.01 * F / K);
  ASSERT_GT(free, gap - d);
  // With it, it stops higher, where the contact carries F - K delta, and that
  // is k (1 - r/d)^2 at the tip's distance r = gap - delta from the vertex.
  const double delta = tipDeflection(gap, F, d, k);
  EXPECT_LT(delta, free - 0.1 * F / K);
  const double r = gap - delta;
  ASSERT_LT(r, d);
  const double carried = F - K * delta;
  const double repulsion = k * std::pow(1.0 - r / d, 2);
  EXPECT_GT(repulsion, 0.2 * F);
  EXPECT_NEAR(carried, repulsion, 0.02 * F);
}

}  // namespace
}  // namespace rodmesh
