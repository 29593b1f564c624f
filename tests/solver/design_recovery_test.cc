// The reduced-space optimizer recovers hidden designs: targets are the
// equilibria of a design inside the design space (random control values), the
// optimizer starts from the uniform default design and must cut the RMS error
// at least 20x; radii, rest shape and both. Also: radius bounds hold at every
// vertex, and the thread count does not change the result.
#include "model/design_space.hh"
#include "solver/design_optimizer.hh"
#include "tests/testutil/design_problems.hh"

#include <gtest/gtest.h>

#include <random>

namespace rodmesh {
namespace {

using testutil::HiddenDesignProblem;
HiddenDesignProblem makeProblem(bool radii, bool rest, unsigned seed) {
  return testutil::hiddenDesignSheet(radii, rest, seed, 2);
}

struct Case {
  bool radii, rest;
};

class DesignRecovery : public testing::TestWithParam<Case> {};

TEST_P(DesignRecovery, CutsTheRmsErrorOfTheDefaultDesignTwentyfold) {
  const Case c = GetParam();
  const HiddenDesignProblem pr = makeProblem(c.radii, c.rest, 3);
  SceneModel model(pr.scene);
  const DesignSpace space(pr.scene, model.effects());
  DesignOptimizerOptions o;
  o.maxIterations = 400;
  const DesignOptimizerResult r = optimizeReduced(model, space, o);
  ASSERT_NE(r.outcome, Outcome::NumericalFailure) << r.message;
  ASSERT_GT(r.initialRms, 1e-4) << "the hidden design must differ visibly from the default one";
  EXPECT_LT(r.rms, r.initialRms / 20.0) << "initial " << r.initialRms << " m, final " << r.rms << " m, "
                                        << r.message;
  // Bounds hold at every vertex, and the final design's equilibria (re-solved
  // from rest) give the RMS the optimizer reports.
  for (const Vec2& rr : r.design.radii) {
    EXPECT_GE(rr.minCoeff(), pr.scene.design.radiusMin - 1e-15);
    EXPECT_LE(rr.maxCoeff(), pr.scene.design.radiusMax + 1e-15);
  }
  const SimulationResult sim = simulateAll(model, r.design, NewtonOptions{});
  ASSERT_TRUE(sim.allConverged);
  const double rms = rmsError(sim);
  EXPECT_NEAR(rms, r.rms, 1e-3 * r.initialRms);
}

INSTANTIATE_TEST_SUITE_P(Parameters, DesignRecovery,
                         testing::Values(Case{true, false}, Case{false, true}, Case{true, true}),
                         [](const testing::TestParamInfo<Case>& i) {
                           return std::string(i.param.radii ? "radii" : "") + (i.param.radii && i.param.rest ? "_" : "") +
                                  (i.param.rest ? "rest_shape" : "");
                         });

TEST(DesignRecovery, ThreadCountDoesNotChangeTheResult) {
  const HiddenDesignProblem pr = makeProblem(true, false, 5);
  DesignOptimizerOptions o;
  o.maxIterations = 15;
  SceneModel m1(pr.scene), m2(pr.scene);
  const DesignSpace s1(pr.scene, m1.effects()), s2(pr.scene, m2.effects());
  o.threads = 1;
  const DesignOptimizerResult a = optimizeReduced(m1, s1, o);
  o.threads = 2;
  const DesignOptimizerResult b = optimizeReduced(m2, s2, o);
  ASSERT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.objective, b.objective);
  EXPECT_EQ((a.controls.radii - b.controls.radii).cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace rodmesh
