// Finite-difference design derivatives of the reduced method
// (DesignDerivatives, solver/design_optimizer.hh) against the exact adjoint
// gradient, which reduced_gradient_test.cc checks against Taylor remainders:
//   fd          the paper's recipe, dF/dz by central differences of the
//               forces at the fixed equilibrium (no re-solve);
//   fd-resolve  central differences of the objective, every probe re-solving
//               every pose from the equilibrium at z.
// On the network with connections, gravity, twist, a clamp and supports that
// move with the rest shape, radii and rest shape free together, 3D and planar.
#include "model/design_space.hh"
#include "solver/design_optimizer.hh"
#include "tests/testutil/design_problems.hh"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace rodmesh {
namespace {

struct Case {
  bool planar;
  DesignDerivatives mode;
  double relativeError;  // bound on |g_fd - g_exact| / |g_exact|
};

class FdDesignDerivatives : public testing::TestWithParam<Case> {};

TEST_P(FdDesignDerivatives, AgreeWithTheExactAdjointGradient) {
  const Case c = GetParam();
  const Scene scene = testutil::designNetwork(c.planar);
  SceneModel model(scene);
  const DesignSpace space(scene, model.effects());
  const TargetObjective objective(scene, model.effects());
  const DesignPhase phase{true, true, space.numLevels() - 1};
  const ControlValues base = space.initialControls(scene);
  const NewtonOptions newton;  // the optimizer's default stopping rule
  std::vector<PoseState> warm;
  const Design d0 = space.toDesign(base);
  for (int p = 0; p < model.numPoses(); ++p) warm.push_back(model.pose(p).restState(d0));
  const Eigen::VectorXd z0 = space.pack(phase, base);
  const Eigen::VectorXd scale = designVariableScale(space, phase, scene);

  ReducedObjective exact(model, space, objective, phase, base, newton, 1, warm);
  double fe;
  Eigen::VectorXd ge;
  ASSERT_TRUE(exact.evaluate(z0, fe, &ge));
  ASSERT_GT(ge.norm(), 0.0);

  ReducedObjective fd(model, space, objective, phase, base, newton, 1, warm);
  fd.setDesignDerivatives(c.mode, scale);
  double ff;
  Eigen::VectorXd gf;
  ASSERT_TRUE(fd.evaluate(z0, ff, &gf));
  EXPECT_EQ(ff, fe);  // the same equilibria: only the gradient differs
  ASSERT_EQ(gf.size(), ge.size());
  // Compare in the optimizer's scaled variables (gradient times scale), where
  // radii and displacements are comparable.
  const Eigen::VectorXd a = ge.cwiseProduct(scale), b = gf.cwiseProduct(scale);
  const double rel = (b - a).norm() / a.norm();
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", rel);
  RecordProperty("relative_error", buf);
  EXPECT_LT(rel, c.relativeError) << "relative error " << rel;
  // No single component is badly off (relative to the largest one).
  Eigen::Index worst;
  const double e = (b - a).cwiseAbs().maxCoeff(&worst);
  EXPECT_LT(e, c.relativeError * a.cwiseAbs().maxCoeff())
      << "component " << worst << ": exact " << a[worst] << ", fd " << b[worst];
}

std::string caseName(const testing::TestParamInfo<Case>& i) {
  return std::string(i.param.planar ? "planar_" : "spatial_") +
         (i.param.mode == DesignDerivatives::FiniteDifference ? "fd" : "fd_resolve");
}

INSTANTIATE_TEST_SUITE_P(Modes, FdDesignDerivatives,
                         testing::Values(Case{false, DesignDerivatives::FiniteDifference, 1e-8},
                                         Case{true, DesignDerivatives::FiniteDifference, 1e-8},
                                         Case{false, DesignDerivatives::FiniteDifferenceResolve, 1e-4},
                                         Case{true, DesignDerivatives::FiniteDifferenceResolve, 1e-4}),
                         caseName);

TEST(FdDesignDerivativesOptions, NamesAndScaleSize) {
  EXPECT_STREQ(designDerivativesName(DesignDerivatives::Exact), "exact");
  EXPECT_STREQ(designDerivativesName(DesignDerivatives::FiniteDifference), "fd");
  EXPECT_STREQ(designDerivativesName(DesignDerivatives::FiniteDifferenceResolve), "fd-resolve");
  const Scene scene = testutil::designNetwork(false);
  SceneModel model(scene);
  const DesignSpace space(scene, model.effects());
  const TargetObjective objective(scene, model.effects());
  const DesignPhase phase{true, false, 0};
  ReducedObjective ro(model, space, objective, phase, space.initialControls(scene), NewtonOptions{}, 1, {});
  EXPECT_THROW(ro.setDesignDerivatives(DesignDerivatives::FiniteDifference, Eigen::VectorXd::Ones(1)),
               std::invalid_argument);
}

}  // namespace
}  // namespace rodmesh
