// The reduced-space optimizer recovers hidden designs: targets are the
// equilibria of a design inside the design space (random control values), the
// optimizer starts from the uniform default design and must cut the RMS error
// at least 20x; radii, rest shape and both. Also: radius bounds hold at every
// vertex, and the thread count does not change the result.
#include "meshing/grid.hh"
#include "model/design_space.hh"
#include "solver/design_optimizer.hh"

#include <gtest/gtest.h>

#include <random>

namespace rodmesh {
namespace {

using namespace meshing;

// A small hexagonal sheet clamped along its left side, with a gravity pose and
// a pulled-and-lifted pose; targets from a hidden design.
struct Problem {
  Scene scene;
  double hiddenRadiusMin = 1e9, hiddenRadiusMax = 0;
};

Problem makeProblem(bool radii, bool rest, unsigned seed) {
  GridOptions g;
  g.width = g.height = 0.06;
  g.cellsX = g.cellsY = 2;
  g.rodVertices = 5;
  g.gravity = Vec3(0, 0, -9.81);
  g.fixSides = {GridSide::Left};
  g.designRadii = radii;
  g.designRestShape = rest;
  g.radiusMin = 0.0008;
  g.radiusMax = 0.004;
  Problem pr;
  Scene s = makeGridSheet(g).scene;
  std::vector<ClampedVertex> clamps;
  for (const FixedVertex& f : s.poses.at(0).fixed) clamps.push_back({f.vertex});
  const std::vector<int> right = sideVertices(s, GridSide::Right, 1e-9);
  s.poses.clear();
  Pose sag;
  sag.name = "sag";
  sag.clamped = clamps;
  Pose lift = sag;
  lift.name = "lift";
  lift.forces.push_back({right.front(), Vec3(0.0, 0.02, 0.01)});
  s.poses = {sag, lift};
  s.gravity = Vec3(0, 0, -9.81);
  s.effects.reset();

  // Hidden design: random control values inside the bounds.
  SceneModel model0(s);
  const DesignSpace space(s, model0.effects());
  ControlValues hidden = space.initialControls(s);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  if (radii)
    for (int i = 0; i < hidden.radii.rows(); ++i)
      for (int k = 0; k < 2; ++k) hidden.radii(i, k) = 0.0012 + 0.0014 * U(rng);
  if (rest)
    for (int i = 0; i < hidden.displacement.rows(); ++i) hidden.displacement(i, 2) = 0.003 * (U(rng) - 0.5);
  const Design hd = space.toDesign(hidden);
  Scene h = s;
  h.vertices = hd.restPositions;
  h.radii = hd.radii;
  SceneModel hm(h);
  const SimulationResult sim = simulateAll(hm, Design::fromScene(h), NewtonOptions{});
  EXPECT_TRUE(sim.allConverged);
  for (int p = 0; p < 2; ++p) s.poses[p].target = sim.poses[p].positions;
  for (const Vec2& r : hd.radii) {
    pr.hiddenRadiusMin = std::min(pr.hiddenRadiusMin, r.minCoeff());
    pr.hiddenRadiusMax = std::max(pr.hiddenRadiusMax, r.maxCoeff());
  }
  pr.scene = s;
  return pr;
}

struct Case {
  bool radii, rest;
};

class DesignRecovery : public testing::TestWithParam<Case> {};

TEST_P(DesignRecovery, CutsTheRmsErrorOfTheDefaultDesignTwentyfold) {
  const Case c = GetParam();
  const Problem pr = makeProblem(c.radii, c.rest, 3);
  SceneModel model(pr.scene);
  const DesignSpace space(pr.scene, model.effects());
  DesignOptimizerOptions o;
  o.maxIterations = 400;
  const DesignOptimizerResult r = optimizeReduced(model, space, o);
  ASSERT_NE(r.status.outcome, Outcome::NumericalFailure) << r.status.message;
  ASSERT_GT(r.initialRms, 1e-4) << "the hidden design must differ visibly from the default one";
  EXPECT_LT(r.rms, r.initialRms / 20.0) << "initial " << r.initialRms << " m, final " << r.rms << " m, "
                                        << r.status.message;
  // Bounds hold at every vertex, and the final design's equilibria (re-solved
  // from rest) give the RMS the optimizer reports.
  for (const Vec2& rr : r.design.radii) {
    EXPECT_GE(rr.minCoeff(), pr.scene.design.radiusMin - 1e-15);
    EXPECT_LE(rr.maxCoeff(), pr.scene.design.radiusMax + 1e-15);
  }
  const SimulationResult sim = simulateAll(model, r.design, NewtonOptions{});
  ASSERT_TRUE(sim.allConverged);
  double ss = 0.0;
  for (int p = 0; p < model.numPoses(); ++p)
    for (std::size_t v = 0; v < sim.poses[p].positions.size(); ++v)
      ss += (sim.poses[p].positions[v] - pr.scene.poses[p].target[v]).squaredNorm();
  const double rms = std::sqrt(ss / (model.numPoses() * pr.scene.vertices.size()));
  EXPECT_NEAR(rms, r.rms, 1e-3 * r.initialRms);
}

INSTANTIATE_TEST_SUITE_P(Parameters, DesignRecovery,
                         testing::Values(Case{true, false}, Case{false, true}, Case{true, true}),
                         [](const testing::TestParamInfo<Case>& i) {
                           return std::string(i.param.radii ? "radii" : "") + (i.param.radii && i.param.rest ? "_" : "") +
                                  (i.param.rest ? "rest_shape" : "");
                         });

TEST(DesignRecovery, ThreadCountDoesNotChangeTheResult) {
  const Problem pr = makeProblem(true, false, 5);
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
