// Tests of solver/minimizer (the one Newton minimizer behind the static solve
// and the backward-Euler step) and of the solve summary every pose solve
// reports (model/outcome.hh).
//
// References:
//   - a time step's answer is a stationary point of the incremental potential
//     Phi(u) = E(u) + 1/(2 h^2) (u - u_pred)^T M (u - u_pred): its force
//     residual, evaluated here from the model's gradient and the inertia term
//     written out independently, vanishes to the step's tolerance;
//   - as h grows the inertia term vanishes and the step's answer tends to the
//     static equilibrium (for a convex, loaded cantilever: the unique one);
//   - a solve that stops before the full load returns no usable state.
#include "solver/minimizer.hh"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>

#include "model/scene_model.hh"
#include "solver/mass.hh"
#include "solver/newton.hh"
#include "tests/testutil/scenes.hh"

namespace rodmesh {
namespace {

// A cantilever along x with twist, sagging under its weight and a tip force.
Scene loadedCantilever() {
  Scene s = testutil::cantilever(12, 0.12, 0.0015, 0.001, Vec3::UnitZ());
  s.effects = std::vector<Effect>{Effect::Stretch, Effect::Bend, Effect::Twist};
  s.gravity = Vec3(0.0, 0.0, -9.81);
  s.poses[0].forces.push_back(PointForce{12, Vec3(0.0, 0.002, -0.004)});
  return s;
}

// One backward-Euler step of size h from rest (u_pred = u_0 = the rest
// state), the full load applied at once, by the minimizer with the time
// step's settings (as solver/dynamics.cc sets them).
struct TimeStepFromRest {
  Scene scene = loadedCantilever();
  SceneModel model{scene};
  Design design = Design::fromScene(scene);
  const PoseSystem& sys = model.pose(0);
  Eigen::VectorXd mass = dofMasses(sys, lumpedVertexMasses(model.network(), design, scene.material.density));
  InertiaTerm inertia;
  PoseState state = sys.restState(design);
  NewtonReport report;

  explicit TimeStepFromRest(double invH2) {
    inertia.mass = &mass;
    inertia.invH2 = invH2;
    inertia.predicted = sys.restDofs(design);
    state.loadFactor = 1.0;
    MinimizerSettings s;
    s.scaleFromStart = true;
    s.tolerance = 1e-10;
    s.maxIterations = 50;
    s.stableOnly = false;
    s.maxEscapes = 0;
    s.trustRegion = false;
    s.reanchor = false;
    s.inertia = &inertia;
    MinimizerWorkspace ws;
    report = minimizeEnergy(sys, design, state, s, ws);
  }
};

TEST(Minimizer, ATimeStepEndsAtAStationaryPointOfTheIncrementalPotential) {
  const double h = 2e-3;
  const TimeStepFromRest step(1.0 / (h * h));
  const NewtonReport& r = step.report;
  ASSERT_TRUE(r.converged()) << r.message;
  EXPECT_TRUE(r.usable);
  EXPECT_GT(r.iterations, 0);

  // Phi's residual, from the model's gradient and the inertia term written
  // out here, at the answer against the step's starting imbalance.
  auto phiResidual = [&](const Eigen::VectorXd& u) {
    Eigen::VectorXd g;
    step.sys.evaluate(PoseState{u, step.state.charts, 1.0, {}}, step.design, &g, nullptr);
    for (int i = 0; i < step.sys.numDofs(); ++i) g[i] += step.mass[i] / (h * h) * (u[i] - step.inertia.predicted[i]);
    return step.sys.forceResidual(g).norm();
  };
  const double start = phiResidual(step.inertia.predicted);
  ASSERT_GT(start, 0.0);
  EXPECT_LE(phiResidual(step.state.u), 1e-9 * start);
  // It moved: the tip went down, and far less than the rod's length.
  const Vec3 tip = step.sys.positions(step.state, step.design)[12];
  EXPECT_LT(tip.z(), -1e-9);
  EXPECT_GT(tip.z(), -0.01);
}

TEST(Minimizer, ALongTimeStepEndsAtTheStaticEquilibrium) {
  // h = 1e6 s: the inertia term is ~1e-12 of the stiffness.
  const TimeStepFromRest step(1e-12);
  ASSERT_TRUE(step.report.converged()) << step.report.message;

  PoseState equilibrium = step.sys.restState(step.design);
  NewtonOptions no;
  no.tolerance = 1e-11;
  ASSERT_TRUE(solveEquilibrium(step.sys, step.design, equilibrium, no).converged());
  const std::vector<Vec3> xs = step.sys.positions(equilibrium, step.design);
  const double sag = (xs[12] - step.scene.vertices[12]).norm();
  ASSERT_GT(sag, 1e-3);
  const std::vector<Vec3> x = step.sys.positions(step.state, step.design);
  double err = 0.0;
  for (std::size_t v = 0; v < x.size(); ++v) err = std::max(err, (x[v] - xs[v]).norm());
  EXPECT_LT(err, 1e-6 * sag);
}

TEST(SolveSummary, AStaticSolveStoppedBeforeTheFullLoadIsNotUsable) {
  const Scene s = loadedCantilever();
  SceneModel model(s);
  const Design d = Design::fromScene(s);
  const PoseSystem& sys = model.pose(0);

  PoseState done = sys.restState(d);
  const NewtonReport ok = solveEquilibrium(sys, d, done, NewtonOptions{});
  ASSERT_TRUE(ok.converged()) << ok.message;
  EXPECT_TRUE(ok.usable);
  EXPECT_EQ(ok.loadFactor, 1.0);
  EXPECT_EQ(ok.brief().rfind("converged after ", 0), 0u) << ok.brief();

  // Stopped by its caller at once: the state returned is the rest state.
  std::atomic<bool> stop{true};
  NewtonOptions stopped;
  stopped.cancel = &stop;
  PoseState st = sys.restState(d);
  const NewtonReport r = solveEquilibrium(sys, d, st, stopped);
  EXPECT_EQ(r.outcome, Outcome::TimeLimit) << r.message;
  EXPECT_FALSE(r.converged());
  EXPECT_FALSE(r.usable);
  EXPECT_LT(r.loadFactor, 1.0);
  EXPECT_NE(r.brief().find("time_limit"), std::string::npos) << r.brief();
  EXPECT_NE(r.brief().find("not usable"), std::string::npos) << r.brief();
}

}  // namespace
}  // namespace rodmesh
