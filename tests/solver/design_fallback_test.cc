// The design `rodmesh optimize` archives (solver/design_fallback.hh): the
// bounded list of fallback designs, and the choice of the first design whose
// every pose re-solves from rest when the final one does not.
//
// The case (testutil::fallbackCase): a cantilever bent far by a tip force,
// targets from a design with 0.6 times its radii, Newton limited to 6
// iterations per load step (the budget of `rodmesh simulate --max-iter 6`)
// for the optimizer's solves and the re-solves alike. Warm-started from the
// previous design's equilibrium (the optimizer's continuation) that is
// plenty; from rest, the thin designs' large deflection is out of its reach,
// the thicker ones' is not. So the optimizer follows the radii down to designs
// it cannot re-solve from rest, and an earlier design must be archived. (With
// the default budget, 100 iterations per load step, we found no small scene
// whose optimized design fails from rest; the design study's Smiley, 2663
// vertices, is one: benchmarks/results/design_study.md.)
#include "solver/design_fallback.hh"

#include <gtest/gtest.h>

#include <cmath>

#include "model/design_space.hh"
#include "solver/design_optimizer.hh"
#include "tests/testutil/design_problems.hh"

namespace rodmesh {
namespace {

// A reduced run of `iterations` iterations with these Newton options.
DesignOptimizerResult reducedRun(const SceneModel& model, const DesignSpace& space, int iterations,
                                 const NewtonOptions& newton) {
  DesignOptimizerOptions o;
  o.maxIterations = iterations;
  o.newton = newton;
  return optimizeReduced(model, space, o);
}

// What acceptance does with an archive: a scene carrying the archived rest
// positions and radii, solved from rest as `rodmesh simulate` solves it
// (tests/cli/optimize_cli_test.cc runs the executable itself).
SimulationResult resimulate(const Scene& scene, const Design& d, const NewtonOptions& newton) {
  const Scene s = sceneOfDesign(scene, d);
  SceneModel m(s);
  return simulateAll(m, Design::fromScene(s), newton);
}

double maxDistance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double m = 0.0;
  for (std::size_t v = 0; v < a.size(); ++v) m = std::max(m, (a[v] - b[v]).norm());
  return m;
}

ControlValues scaledControls(const DesignSpace& space, const Scene& s, double radiusScale) {
  ControlValues c = space.initialControls(s);
  c.radii *= radiusScale;
  return c;
}

// A pose with nothing applied (no gravity, no force, held vertices at rest)
// is solved from rest as no load, without a loading path: its force at rest
// is the rest shape's round-off alone (nonzero here), which a path would
// chase through thousands of load steps (6 s for one pose of 98 vertices in
// benchmarks/other_model's shape_small before).
TEST(LoadingPath, APoseWithNothingAppliedIsNoLoad) {
  testutil::HiddenDesignProblem pr = testutil::hiddenDesignSheet(false, true, 3, 2);
  pr.scene.gravity.reset();
  for (Pose& p : pr.scene.poses) {
    p.forces.clear();
    p.twistingMoments.clear();
    for (FixedVertex& f : p.fixed) f.position.reset();
  }
  SceneModel model(pr.scene);
  const DesignSpace space(pr.scene, model.effects());
  const Design d = space.toDesign(space.initialControls(pr.scene));
  const PoseSystem& sys = model.pose(0);
  PoseState s = sys.restState(d);
  const double scale = loadScale(sys, d);
  ASSERT_GT(scale, 0.0) << "the rest shape's round-off must be there for this test";
  const NewtonReport r = solveEquilibrium(sys, d, s, NewtonOptions{});
  EXPECT_TRUE(r.converged()) << r.message;
  EXPECT_EQ(r.loadSteps, 0) << r.message;
  EXPECT_EQ(r.message, "no load: rest configuration");
  EXPECT_EQ(s.loadFactor, 1.0);
  EXPECT_EQ((s.u - sys.restState(d).u).cwiseAbs().maxCoeff(), 0.0);
  // A light force at the free corner is a load again, however light.
  pr.scene.poses[0].forces.push_back({static_cast<int>(pr.scene.vertices.size()) - 1, Vec3(0, 0, -1e-9)});
  SceneModel loaded(pr.scene);
  PoseState t = loaded.pose(0).restState(d);
  const NewtonReport q = solveEquilibrium(loaded.pose(0), d, t, NewtonOptions{});
  EXPECT_NE(q.message, "no load: rest configuration");
  EXPECT_GT((t.u - loaded.pose(0).restState(d).u).cwiseAbs().maxCoeff(), 0.0);
}

TEST(DesignFallbacks, KeepBestFirstWithinTheirCapacitySpreadOverTheRun) {
  const Scene s = testutil::bentCantilever(2e-3);
  SceneModel model(s);
  const DesignSpace space(s, model.effects());
  DesignFallbacks list(4);
  const double objectives[] = {100, 10, 1, 0.99, 0.98, 0.97};
  for (int i = 0; i < 6; ++i)
    list.add(scaledControls(space, s, 1.0 - 0.05 * i), objectives[i], 0.1, "design " + std::to_string(i));
  // Ignored: a non-finite objective, and controls already held.
  list.add(scaledControls(space, s, 0.5), std::nan(""), 0.1, "nan");
  list.add(scaledControls(space, s, 1.0), 0.5, 0.1, "duplicate");
  const std::vector<FallbackDesign>& d = list.designs();
  ASSERT_EQ(d.size(), 4u);
  // Best first; the designs crowding near the best give way, the early ones stay.
  EXPECT_EQ(d[0].label, "design 5");
  EXPECT_EQ(d[1].label, "design 4");
  EXPECT_EQ(d[2].label, "design 1");
  EXPECT_EQ(d[3].label, "design 0");
}

// The design monitor's confirmed design (re-solved from rest during the run)
// is pinned: in a full list it would be the one dropped (closest to a better
// design, as designs near the end of a run are), but it stays, without
// taking an unpinned design's place; adding a held design pinned pins it.
TEST(DesignFallbacks, KeepPinnedDesignsBeyondTheirCapacity) {
  const Scene s = testutil::bentCantilever(2e-3);
  SceneModel model(s);
  const DesignSpace space(s, model.effects());
  DesignFallbacks list(3);
  const double objectives[] = {100, 10, 1};
  for (int i = 0; i < 3; ++i)
    list.add(scaledControls(space, s, 1.0 - 0.05 * i), objectives[i], 0.1, "design " + std::to_string(i));
  list.add(scaledControls(space, s, 0.8), 1.001, 0.1, "confirmed", /*pinned=*/true);
  list.add(scaledControls(space, s, 0.7), 0.5, 0.1, "design 3");
  std::vector<std::string> labels;
  for (const FallbackDesign& d : list.designs()) labels.push_back(d.label);
  // Unpinned: designs 3, 1, 0 (design 2 was nearest a better one: the
  // confirmed design, 1.001 against 1, would have been dropped in its place).
  EXPECT_EQ(labels, (std::vector<std::string>{"design 3", "confirmed", "design 1", "design 0"}));
  EXPECT_TRUE(list.designs()[1].pinned);
  // A held design added pinned becomes pinned, with the new label.
  list.add(scaledControls(space, s, 1.0), 100, 0.1, "design 0 confirmed", /*pinned=*/true);
  ASSERT_EQ(list.designs().size(), 4u);
  EXPECT_TRUE(list.designs()[3].pinned);
  EXPECT_EQ(list.designs()[3].label, "design 0 confirmed");
}

// An optimizer that designed the inverted equilibrium (its own equilibria on
// that branch, RMS 0.1 mm there) designed one the loaded arch never reaches:
// the archived design is marked off the loading path, the gap (about twice
// the rise) and the tolerance are reported, the archived positions are the
// loading path's. The same design with the loading path's own equilibria is
// on it.
TEST(DesignFallback, DesignWhoseEquilibriaAreNotTheLoadingPathsIsMarkedOffThePath) {
  Scene s = testutil::invertibleArch();
  SceneModel model(s);
  const DesignSpace space(s, model.effects());
  DesignOptimizerResult r;
  r.controls = space.initialControls(s);
  r.design = space.toDesign(r.controls);
  const PoseSystem& sys = model.pose(0);
  // The inverted branch: Newton from the mirrored arch at the full load.
  std::vector<Vec3> mirrored = s.vertices;
  for (Vec3& x : mirrored) x.z() = -x.z();
  PoseState inverted = sys.restState(r.design);
  inverted.u = sys.dofsFrom(mirrored, Eigen::VectorXd());
  inverted.loadFactor = 1.0;
  ASSERT_TRUE(solveEquilibrium(sys, r.design, inverted, NewtonOptions{}).converged());
  const std::vector<Vec3> down = sys.positions(inverted, r.design);
  ASSERT_LT(down[20].z(), -0.04);
  s.poses[0].target = down;
  SceneModel targeted(s);
  r.states = {inverted};
  r.rms = 1e-4;
  r.initialRms = 1e-4;
  const ArchivedDesign a = chooseArchivedDesign(targeted, space, r, NewtonOptions{});
  ASSERT_TRUE(a.allConverged);
  EXPECT_TRUE(a.offPath);
  EXPECT_FALSE(a.fallback);
  EXPECT_GT(a.gap, 0.08);
  EXPECT_NEAR(a.gapTolerance, 1e-5, 1e-12) << "a tenth of the optimizer's RMS";
  EXPECT_GT(a.simulation.poses[0].positions[20].z(), 0.0) << "archived: the loading path's equilibrium, up";
  EXPECT_NE(a.note.find("loading path"), std::string::npos) << a.note;
  EXPECT_GT(a.rms, 0.05);

  // The loading path's own equilibrium as the optimizer's: on the path.
  PoseState up = sys.restState(r.design);
  ASSERT_TRUE(solveEquilibrium(sys, r.design, up, NewtonOptions{}).converged());
  r.states = {up};
  const ArchivedDesign b = chooseArchivedDesign(targeted, space, r, NewtonOptions{});
  EXPECT_FALSE(b.offPath) << b.note;
  EXPECT_LT(b.gap, b.gapTolerance);
  EXPECT_TRUE(b.note.empty()) << b.note;
}

TEST(DesignFallback, FinalDesignThatResolvesFromRestIsArchived) {
  Scene s = testutil::bentCantilever(2e-3);
  testutil::setScaledRadiiTargets(s, 0.9);
  SceneModel model(s);
  const DesignSpace space(s, model.effects());
  const DesignOptimizerResult r = reducedRun(model, space, 10, NewtonOptions{});
  const ArchivedDesign a = chooseArchivedDesign(model, space, r, NewtonOptions{});
  EXPECT_FALSE(a.fallback);
  EXPECT_TRUE(a.allConverged);
  EXPECT_TRUE(a.note.empty()) << a.note;
  EXPECT_TRUE(sameControls(a.controls, r.controls));
  EXPECT_LE(a.rms, r.initialRms);
}

TEST(DesignFallback, ReducedRunArchivesTheBestEarlierDesignThatResolvesFromRest) {
  const Scene s = testutil::fallbackCase();
  const NewtonOptions newton = testutil::fallbackCaseNewton();
  SceneModel model(s);
  const DesignSpace space(s, model.effects());
  const DesignOptimizerResult r = reducedRun(model, space, 60, newton);
  SCOPED_TRACE(r.message);
  ASSERT_NE(r.outcome, Outcome::NumericalFailure);
  ASSERT_FALSE(r.fallbacks.empty());
  for (std::size_t i = 1; i < r.fallbacks.size(); ++i)
    EXPECT_LE(r.fallbacks[i - 1].objective, r.fallbacks[i].objective) << "best first";
  // The premise: the optimizer got further on its own equilibria than a
  // solve from rest can follow.
  EXPECT_LT(r.rms, 0.5 * r.initialRms);
  ASSERT_FALSE(resimulate(s, r.design, newton).allConverged);

  const ArchivedDesign a = chooseArchivedDesign(model, space, r, newton);
  SCOPED_TRACE(a.note);
  ASSERT_TRUE(a.fallback);
  ASSERT_TRUE(a.allConverged);
  EXPECT_NE(a.label, "the initial design") << "a better design than the initial one re-solves from rest";
  EXPECT_NE(a.note.find("could not be re-solved from rest"), std::string::npos);
  EXPECT_NE(a.note.find(a.label), std::string::npos) << "the note names the design archived";
  EXPECT_NE(a.note.find("pose 'bend'"), std::string::npos) << "and the pose that failed";
  ASSERT_TRUE(std::isfinite(a.rms));
  EXPECT_LE(a.rms, r.initialRms);
  EXPECT_LT(a.rms, 0.9 * r.initialRms) << "the fallback improves on the initial design";
  // Self-consistent: the design is the controls' design, and the archived
  // positions are what a solve from rest under it gives.
  const Design d = space.toDesign(a.controls);
  for (int v = 0; v < d.numVertices(); ++v) {
    EXPECT_EQ(d.radii[v], a.design.radii[v]);
    EXPECT_EQ(d.restPositions[v], a.design.restPositions[v]);
  }
  const SimulationResult check = resimulate(s, a.design, newton);
  ASSERT_TRUE(check.allConverged);
  EXPECT_LT(maxDistance(check.poses[0].positions, a.simulation.poses[0].positions), 1e-8);
  EXPECT_NEAR(*check.poses[0].rmsError, a.rms, 1e-12);
}

// When not even the initial design re-solves from rest, the final design is
// archived as it is, and the note says so.
TEST(DesignFallback, NoDesignThatResolvesKeepsTheFinalOneAndSaysSo) {
  Scene s = testutil::bentCantilever(5e-3);
  testutil::setScaledRadiiTargets(s, 0.6);
  SceneModel model(s);
  const DesignSpace space(s, model.effects());
  NewtonOptions newton;
  newton.maxIterations = 3;  // from rest, every design fails under this load (even the initial one)
  DesignOptimizerResult r;
  r.controls = scaledControls(space, s, 0.6);
  r.design = space.toDesign(r.controls);
  r.rms = 1e-4;
  r.initialRms = 0.05;
  DesignFallbacks list;
  list.add(scaledControls(space, s, 0.8), 1e-3, 0.01, "the design of radii level 0, iteration 3");
  r.fallbacks = list.designs();
  const ArchivedDesign a = chooseArchivedDesign(model, space, r, newton);
  EXPECT_FALSE(a.fallback);
  EXPECT_FALSE(a.allConverged);
  EXPECT_TRUE(sameControls(a.controls, r.controls));
  EXPECT_NE(a.note.find("not even the initial one (2 earlier designs tried)"), std::string::npos) << a.note;
  EXPECT_TRUE(std::isfinite(a.rms));
  for (const Vec3& x : a.simulation.poses[0].positions) EXPECT_TRUE(x.allFinite());
}

}  // namespace
}  // namespace rodmesh
