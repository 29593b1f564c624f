// The term block with internal variables (model/terms/tie.hh): an
// elastic-perfectly-plastic tie whose rest length lives in the pose state.
// Its energy and force against the formulas of docs/formats.md, the update
// rule (return mapping), the state's internal variables as inputs that
// solvers carry unchanged, and a cantilever held down by a tie: elastic
// below the yield load and plastic above it against the linear beam's
// closed forms, with the permanent set after unloading that only the
// carried rest length can explain; a dynamic run records the same yielding.
// (Its Taylor tests, elastic and plastic, are the "tie" cases of
// derivatives_test.cc.)
#include "model/pose_system.hh"
#include "model/scene_model.hh"
#include "solver/dynamics.hh"
#include "solver/mass.hh"
#include "solver/newton.hh"
#include "tests/testutil/scenes.hh"

#include <gtest/gtest.h>

#include <cmath>

namespace rodmesh {
namespace {

constexpr double kLength = 0.1, kRadius = 1e-3, kDrop = 0.02;
constexpr int kEdges = 20;
// Tie stiffness and yield force.
constexpr double kTie = 0.05, kYield = 2e-5;

// A cantilever along +x (clamped at 0, tip at kEdges), a short held rod kDrop
// below the tip, a tie from the tip to that rod's first vertex; pose 0 lifts
// the tip by `force` along +z, pose 1 has no load.
Scene tiedCantilever(double force) {
  Scene s = testutil::cantileverOverHeldRod(kEdges, kLength, kRadius, kDrop);
  const int tip = kEdges, anchor = kEdges + 1;
  Pose& p = s.poses.at(0);
  p.ties.push_back({tip, anchor, kTie, kYield});
  Pose unloaded = p;
  unloaded.name = "unloaded";
  p.forces.push_back({tip, Vec3(0.0, 0.0, force)});
  s.poses.push_back(unloaded);
  return s;
}

// Tip stiffness of the linear cantilever.
double beamStiffness(const Scene& s) {
  return 3.0 * s.material.youngModulus * M_PI * std::pow(kRadius, 4) / 4.0 / std::pow(kLength, 3);
}

double tipLift(const PoseSystem& sys, const PoseState& state, const Design& d) {
  return sys.positions(state, d)[kEdges].z();
}

TEST(TieTerm, EnergyIsTheIncrementalPotentialAndTheUpdateTheReturnMapping) {
  const Scene s = tiedCantilever(0.0);
  const SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  const Design design = Design::fromScene(s);
  const int tie = PoseSystem::termKindIndex("tie");
  ASSERT_GE(tie, 0);
  EXPECT_EQ(PoseSystem::termKinds()[tie].internal, 1);
  ASSERT_EQ(sys.termCount(tie), 1);
  ASSERT_EQ(sys.numInternal(), 1);
  EXPECT_DOUBLE_EQ(sys.initialInternal()[0], kDrop);  // the scene distance
  const int tipDof = sys.vertexDof()[kEdges];
  ASSERT_EQ(sys.dofsPerVertex(), 2);  // planar scene (y = 0)
  const PoseSystem::Terms only = PoseSystem::Terms::only(tie);
  // At rest with a shorter rest length L the tie is stretched by s = kDrop - L:
  // elastic below the yield stretch f/k = 0.4 mm, plastic above.
  for (const double stretch : {1e-4, 3e-4, 1e-3, 5e-3}) {
    PoseState st = sys.restState(design);
    st.internal = Eigen::VectorXd::Constant(1, kDrop - stretch);
    Eigen::VectorXd g;
    const double E = sys.evaluate(st, design, &g, nullptr, only);
    const bool elastic = kTie * stretch <= kYield;
    const double expected = elastic ? 0.5 * kTie * stretch * stretch : kYield * stretch - 0.5 * kYield * kYield / kTie;
    EXPECT_NEAR(E, expected, 1e-12 * expected) << "stretch " << stretch;
    // The tension pulls the tip down towards the anchor: dE/dz = tension.
    const Vec3 grad = sys.effects().planeBasis * g.segment<2>(tipDof);
    EXPECT_NEAR(grad.z(), std::min(kTie * stretch, kYield), 1e-12 * kYield) << "stretch " << stretch;
    EXPECT_NEAR(grad.x(), 0.0, 1e-18);
    // The update: unchanged while elastic; else the rest length that leaves
    // exactly the yield force.
    const std::optional<PoseState> next = sys.advancedInternal(st, design);
    if (elastic) {
      EXPECT_FALSE(next.has_value()) << "stretch " << stretch;
    } else {
      ASSERT_TRUE(next.has_value()) << "stretch " << stretch;
      EXPECT_NEAR(next->internal[0], kDrop - kYield / kTie, 1e-15);
      EXPECT_EQ(next->u, st.u);  // nothing else moves
    }
  }
  // Compressed beyond yield: the rest length follows from the other side.
  PoseState st = sys.restState(design);
  st.internal = Eigen::VectorXd::Constant(1, kDrop + 2e-3);
  const std::optional<PoseState> next = sys.advancedInternal(st, design);
  ASSERT_TRUE(next.has_value());
  EXPECT_NEAR(next->internal[0], kDrop + kYield / kTie, 1e-15);
  // Internal variables of the wrong size are refused.
  st.internal = Eigen::VectorXd::Zero(2);
  EXPECT_THROW(sys.energy(st, design), std::invalid_argument);
}

TEST(TieTerm, HeldCantileverYieldsAndKeepsAPermanentSet) {
  const double K = beamStiffness(tiedCantilever(0.0));
  // Yield load: the tie carries f when the tip has risen f/k.
  const double yieldLoad = kYield * (K + kTie) / kTie;
  // Below it, elastic: the beam and the tie share the load.
  {
    const double F = 0.6 * yieldLoad;
    const Scene s = tiedCantilever(F);
    const SceneModel model(s);
    const PoseSystem& sys = model.pose(0);
    const Design d = Design::fromScene(s);
    PoseState state = sys.restState(d);
    const NewtonReport r = solveEquilibrium(sys, d, state, NewtonOptions{});
    ASSERT_TRUE(r.converged()) << r.message;
    EXPECT_NEAR(tipLift(sys, state, d), F / (K + kTie), 0.01 * F / (K + kTie));
    EXPECT_FALSE(sys.advancedInternal(state, d).has_value());
  }
  // Above it, plastic: the tie holds back only f.
  const double F = 1.5 * yieldLoad;
  const Scene s = tiedCantilever(F);
  const SceneModel model(s);
  const PoseSystem& loaded = model.pose(0);
  const Design d = Design::fromScene(s);
  PoseState state = loaded.restState(d);
  const NewtonReport r = solveEquilibrium(loaded, d, state, NewtonOptions{});
  ASSERT_TRUE(r.converged()) << r.message;
  const double lift = (F - kYield) / K;
  EXPECT_NEAR(tipLift(loaded, state, d), lift, 0.01 * lift);
  // The solve reads the state's internal variables and does not change them.
  EXPECT_EQ(state.internal.size(), 0);
  const std::optional<PoseState> yielded = loaded.advancedInternal(state, d);
  ASSERT_TRUE(yielded.has_value());
  const double L = yielded->internal[0];
  EXPECT_NEAR(L, kDrop + lift - kYield / kTie, 0.01 * lift);
  // Unloaded with that rest length the tip does not come back: the tie,
  // now longer, holds it up where the beam's spring-back balances the tie's
  // (elastic) compression: K z = k (L - kDrop - z).
  const PoseSystem& unloaded = model.pose(1);
  PoseState after = unloaded.restState(d);
  after.internal = yielded->internal;
  const NewtonReport u = solveEquilibrium(unloaded, d, after, NewtonOptions{});
  ASSERT_TRUE(u.converged()) << u.message;
  const double set = kTie * (L - kDrop) / (K + kTie);
  EXPECT_GT(set, 0.3 * lift);
  EXPECT_NEAR(tipLift(unloaded, after, d), set, 0.01 * set);
  EXPECT_EQ(after.internal, yielded->internal);
  EXPECT_FALSE(unloaded.advancedInternal(after, d).has_value());  // unloading stays elastic
  // From the initial rest length instead, the unloaded tip rests at zero.
  PoseState fresh = unloaded.restState(d);
  ASSERT_TRUE(solveEquilibrium(unloaded, d, fresh, NewtonOptions{}).converged());
  EXPECT_NEAR(tipLift(unloaded, fresh, d), 0.0, 1e-9);
}

TEST(TieTerm, ADynamicRunRecordsTheYielding) {
  const double K = beamStiffness(tiedCantilever(0.0));
  const double F = 1.5 * kYield * (K + kTie) / kTie, lift = (F - kYield) / K;
  const Scene s = tiedCantilever(F);
  const SceneModel model(s);
  const PoseSystem& sys = model.pose(0);
  const Design d = Design::fromScene(s);
  // Loads ramped over 20 s, long steps: backward Euler settles at rest.
  DynamicsOptions opt;
  opt.loadRampTime = 20.0;
  opt.maxStep = 2.0;
  BackwardEuler be(sys, d, dofMasses(sys, lumpedVertexMasses(model.network(), d, s.material.density)), opt);
  be.start(sys.restState(d), Eigen::VectorXd::Zero(sys.numDofs()));
  ASSERT_TRUE(be.advanceTo(200.0)) << be.report().message;
  EXPECT_NEAR(tipLift(sys, be.state(), d), lift, 0.01 * lift);
  // The state carries the tie's yielded rest length: tension at the yield force.
  ASSERT_EQ(be.state().internal.size(), 1);
  const double r = (sys.positions(be.state(), d)[kEdges] - s.vertices[kEdges + 1]).norm();
  EXPECT_NEAR(kTie * (r - be.state().internal[0]), kYield, 1e-3 * kYield);
}

}  // namespace
}  // namespace rodmesh
