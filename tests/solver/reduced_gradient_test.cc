// The reduced-space gradient (adjoint, exact design derivatives) against the
// Taylor remainder of the full objective, with every pose's equilibrium
// re-solved at every probe: radii, rest shape and both, on a network with
// connections, gravity, twist, anisotropic sections, a clamp, a vertex held
// at its rest position (it moves with the rest shape) and one held at an
// explicit position; 3D and planar.
#include "model/design_space.hh"
#include "solver/design_optimizer.hh"
#include "tests/testutil/design_problems.hh"
#include "tests/testutil/taylor.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace rodmesh {
namespace {

struct Case {
  bool planar;
  bool radii, rest;
};

class ReducedGradient : public testing::TestWithParam<Case> {};

TEST_P(ReducedGradient, MatchesTaylorRemainderOfTheResolvedObjective) {
  const Case c = GetParam();
  const Scene scene = testutil::designNetwork(c.planar);
  SceneModel model(scene);
  ASSERT_EQ(model.effects().planar, c.planar);
  ASSERT_GT(model.network().numConnections(), 1);
  ASSERT_EQ(model.effects().has(Effect::Twist), !c.planar);
  ASSERT_TRUE(model.effects().has(Effect::Gravity));
  const DesignSpace space(scene, model.effects());
  const TargetObjective objective(scene, model.effects());
  const DesignPhase phase{c.radii, c.rest, space.numLevels() - 1};
  const ControlValues base = space.initialControls(scene);
  NewtonOptions newton;
  newton.tolerance = 1e-13;  // probes must resolve O(h^2) changes of f
  std::vector<PoseState> warm;
  const Design d0 = space.toDesign(base);
  for (int p = 0; p < model.numPoses(); ++p) warm.push_back(model.pose(p).restState(d0));
  ReducedObjective ro(model, space, objective, phase, base, newton, 1, warm);
  const Eigen::VectorXd z0 = space.pack(phase, base);
  double f0;
  Eigen::VectorXd g;
  ASSERT_TRUE(ro.evaluate(z0, f0, &g));
  ro.accept(z0);
  ASSERT_GT(f0, 0.0);
  ASSERT_EQ(g.size(), z0.size());
  // Direction: radii by 10% of their value, displacements by 0.3 mm.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Eigen::VectorXd dz(z0.size());
  const int nr = c.radii ? 2 * space.numNodes(phase.level) : 0;
  for (int i = 0; i < dz.size(); ++i) dz[i] = i < nr ? 0.1 * z0[i] * U(rng) : 3e-4 * U(rng);
  auto f = [&](const Eigen::VectorXd& z) {
    double v = std::nan("");
    EXPECT_TRUE(ro.evaluate(z, v, nullptr));
    return v;
  };
  const auto r = testutil::taylorTestScalar(f, z0, dz, g.dot(dz), 1.0, 10);
  EXPECT_TAYLOR_ORDER(r, 1.85) << r.table();
  // The gradient is not dominated by a single kind of parameter: the rest
  // shape and radii parts are both non-zero when free.
  if (c.radii) {
    EXPECT_GT(g.head(nr).norm(), 0.0);
  }
  if (c.rest) {
    EXPECT_GT(g.tail(g.size() - nr).norm(), 0.0);
  }
}

std::string caseName(const testing::TestParamInfo<Case>& i) {
  std::string s = i.param.planar ? "planar_" : "spatial_";
  if (i.param.radii) s += "radii";
  if (i.param.radii && i.param.rest) s += "_";
  if (i.param.rest) s += "rest";
  return s;
}

INSTANTIATE_TEST_SUITE_P(Parameters, ReducedGradient,
                         testing::Values(Case{false, true, false}, Case{false, false, true}, Case{false, true, true},
                                         Case{true, true, false}, Case{true, true, true}),
                         caseName);

}  // namespace
}  // namespace rodmesh
