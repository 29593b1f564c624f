// The reduced Hessian-vector product (solver/reduced_hessian.hh) on a sheet
// (built with meshing/grid; tests/CMakeLists.txt): the Taylor remainder of
// the re-solved gradient.
#include "model/design_space.hh"
#include "solver/design_optimizer.hh"
#include "solver/reduced_hessian.hh"
#include "tests/testutil/design_problems.hh"
#include "tests/testutil/taylor.hh"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

namespace rodmesh {
namespace {

// A hexagonal sheet with three poses and a hidden radii + rest-shape design
// (the optimizer's test scene): the product at the initial design.
TEST(ReducedHessianSheet, MatchesTaylorRemainderOfTheResolvedGradient) {
  const testutil::HiddenDesignProblem prob = testutil::hiddenDesignSheet(true, true, 5, 3);
  const Scene& scene = prob.scene;
  SceneModel model(scene);
  const DesignSpace space(scene, model.effects());
  const TargetObjective objective(scene, model.effects());
  const DesignPhase phase{true, true, space.numLevels() - 1};
  const ControlValues base = space.initialControls(scene);
  NewtonOptions newton;
  newton.tolerance = 1e-13;
  const Design d0 = space.toDesign(base);
  std::vector<PoseState> warm;
  for (int p = 0; p < model.numPoses(); ++p) warm.push_back(model.pose(p).restState(d0));
  ReducedObjective ro(model, space, objective, phase, base, newton, 1, warm);
  const Eigen::VectorXd z0 = space.pack(phase, base);
  double f0;
  Eigen::VectorXd g0;
  ASSERT_TRUE(ro.evaluate(z0, f0, &g0));
  ro.accept(z0);
  ReducedHessian rh(model, space, objective, phase, 1);
  ASSERT_TRUE(rh.prepare(z0, base, ro.warmStates()));
  EXPECT_LE((rh.gradient() - g0).norm(), 1e-9 * g0.norm());
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::VectorXd dz(z0.size());
  const int nr = 2 * space.numNodes(phase.level);
  for (int i = 0; i < dz.size(); ++i) dz[i] = i < nr ? 0.1 * z0[i] * U(rng) : 3e-4 * U(rng);
  auto grad = [&](const Eigen::VectorXd& z) {
    double f;
    Eigen::VectorXd g;
    EXPECT_TRUE(ro.evaluate(z, f, &g));
    return g;
  };
  const auto r = testutil::taylorTest(grad, z0, dz, rh.product(dz), 1.0, 10);
  EXPECT_TAYLOR_ORDER(r, 1.85) << r.table();
}

}  // namespace
}  // namespace rodmesh
