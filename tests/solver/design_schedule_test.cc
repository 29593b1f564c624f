// The stopping rules of the reduced-space optimizer's schedule
// (solver/design_optimizer.hh, docs/optimization.md "Schedule"): every phase,
// the last one of the alternation included, ends at its cap (radius levels:
// maxLevelIterations; alternation: maxPhaseIterations) or when the
// objective fell by less than phaseRelativeDecrease over phaseWindow
// iterations; the run ends when a rest-shape/radii round lowers the objective
// by less than roundRelativeDecrease, or after maxAlternations rounds.
// Checked on the optimizer's own history, on the shared test network with
// targets that no design reaches exactly (the objective levels off).
#include "model/design_space.hh"
#include "solver/design_optimizer.hh"
#include "tests/testutil/scenes.hh"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace rodmesh {
namespace {

// The star network (3D, eight vertices per arm), clamped at the end of one
// arm, in two poses with opposite loads and the same target: no design
// reaches both, so the objective levels off. Radii and rest shape free.
Scene problem() {
  testutil::StarNetworkOptions o;
  o.verticesPerArm = 8;
  o.lift = 0.0005;
  Scene s = testutil::starNetwork(o);
  s.sourcePath = "<schedule>";
  for (int k = 0; k < 2; ++k) {
    Pose p;
    p.name = "p" + std::to_string(k);
    p.clamped.push_back({16});
    p.forces.push_back({24, Vec3(0.0, 0.0, k == 0 ? -0.01 : 0.01)});
    for (std::size_t v = 0; v < s.vertices.size(); ++v)
      p.target.push_back(s.vertices[v] + Vec3(0.0005 * std::sin(2.0 * v), 0.0, -0.001 * (v % 3)));
    s.poses.push_back(p);
  }
  s.design.present = true;
  s.design.radii = s.design.restShape = true;
  s.design.radiusMin = 0.0005;
  s.design.radiusMax = 0.003;
  s.design.hasRadiusBounds = true;
  s.design.controlPointsPerRod = 4;
  return s;
}

// One phase of the history: its entries [first, last] (indices into
// history; history[first - 1] is the phase's starting point).
struct Segment {
  std::size_t first, last;
  std::string phase;
  int level;
  int iterations() const { return static_cast<int>(last - first + 1); }
};

std::vector<Segment> segments(const std::vector<DesignIterate>& h) {
  std::vector<Segment> out;
  for (std::size_t i = 1; i < h.size(); ++i) {
    if (out.empty() || h[i].phase != h[i - 1].phase || h[i].level != h[i - 1].level)
      out.push_back({i, i, h[i].phase, h[i].level});
    else
      out.back().last = i;
  }
  return out;
}

DesignOptimizerResult optimize(const DesignOptimizerOptions& o) {
  const Scene scene = problem();
  SceneModel model(scene);
  const DesignSpace space(scene, model.effects());
  return optimizeReduced(model, space, o);
}

DesignOptimizerOptions baseOptions() {
  DesignOptimizerOptions o;
  o.maxIterations = 10000;
  o.tolerance = 1e-14;  // the gradient test never ends a phase here
  return o;
}

TEST(DesignSchedule, EveryPhaseKeepsItsCapAndTheRoundLimitEndsTheRun) {
  DesignOptimizerOptions o = baseOptions();
  o.maxLevelIterations = 3;
  o.maxPhaseIterations = 4;
  o.phaseRelativeDecrease = 0.0;  // no window test
  o.roundRelativeDecrease = 0.0;  // no round test
  o.maxAlternations = 3;
  const DesignOptimizerResult r = optimize(o);
  const std::vector<Segment> seg = segments(r.history);
  // Radii at levels 0, 1, 2, then three rounds of rest shape and radii.
  ASSERT_EQ(seg.size(), 9u) << r.message;
  for (std::size_t i = 0; i < seg.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(seg[i].phase, i < 3 || i % 2 == 0 ? "radii" : "rest_shape");
    EXPECT_EQ(seg[i].level, i < 3 ? static_cast<int>(i) : 2);
    EXPECT_EQ(seg[i].iterations(), i < 3 ? 3 : 4) << "the cap, and nothing else, ends the phase";
  }
  EXPECT_EQ(r.iterations, 3 * 3 + 6 * 4) << "the last phase does not get the remaining iterations";
  EXPECT_EQ(r.outcome, Outcome::MaxIterations);
  EXPECT_NE(r.message.find("alternation limit"), std::string::npos) << r.message;
}

TEST(DesignSchedule, APhaseEndsWhenTheObjectiveFellByLessThanTheRelativeDecreaseOverTheWindow) {
  DesignOptimizerOptions o = baseOptions();
  o.maxLevelIterations = o.maxPhaseIterations = 60;
  o.phaseRelativeDecrease = 0.02;
  o.phaseWindow = 3;
  o.roundRelativeDecrease = 0.0;
  o.maxAlternations = 2;
  const DesignOptimizerResult r = optimize(o);
  const std::vector<DesignIterate>& h = r.history;
  const std::vector<Segment> seg = segments(h);
  ASSERT_EQ(seg.size(), 7u) << r.message;
  int endedByWindow = 0;
  for (const Segment& s : seg) {
    SCOPED_TRACE(s.phase + " level " + std::to_string(s.level) + " from history entry " + std::to_string(s.first));
    ASSERT_LE(s.iterations(), o.maxPhaseIterations);
    // f over the phase, starting point included: f[0] = history[first - 1].
    std::vector<double> f;
    for (std::size_t i = s.first - 1; i <= s.last; ++i) f.push_back(h[i].objective);
    auto small = [&](std::size_t k) { return f[k - 3] - f[k] <= 0.02 * std::abs(f[k - 3]); };
    // The test did not hold earlier in the phase ...
    for (std::size_t k = 3; k + 1 < f.size(); ++k) EXPECT_FALSE(small(k)) << "iteration " << k << " of the phase";
    // ... and it ended the phase unless the cap did.
    if (s.iterations() < o.maxPhaseIterations) {
      ASSERT_GE(f.size(), 4u);
      EXPECT_TRUE(small(f.size() - 1));
      ++endedByWindow;
    }
  }
  EXPECT_GE(endedByWindow, 3) << "the window test is exercised";
}

TEST(DesignSchedule, TheRunEndsWhenARoundLowersTheObjectiveByLessThanTheRoundThreshold) {
  DesignOptimizerOptions o = baseOptions();
  o.maxLevelIterations = o.maxPhaseIterations = 8;
  o.phaseRelativeDecrease = 0.0;
  // Round gains of the full alternation, without the round test.
  o.roundRelativeDecrease = 0.0;
  o.maxAlternations = 4;
  const DesignOptimizerResult all = optimize(o);
  std::vector<double> roundStart, roundEnd;
  const std::vector<Segment> seg = segments(all.history);
  ASSERT_EQ(seg.size(), 3u + 2 * 4);
  for (std::size_t i = 3; i < seg.size(); i += 2) {
    roundStart.push_back(all.history[seg[i].first - 1].objective);
    roundEnd.push_back(all.history[seg[i + 1].last].objective);
  }
  std::vector<double> gain;
  for (std::size_t k = 0; k < roundStart.size(); ++k) gain.push_back((roundStart[k] - roundEnd[k]) / roundStart[k]);
  ASSERT_GT(gain[0], gain[1]) << "the first round gains most";
  // A threshold between the first two gains stops the run after round 2.
  o.maxAlternations = 20;
  o.roundRelativeDecrease = 0.5 * (gain[0] + gain[1]);
  const DesignOptimizerResult r = optimize(o);
  EXPECT_EQ(r.outcome, Outcome::Converged) << r.message;
  EXPECT_NE(r.message.find("round 2"), std::string::npos) << r.message;
  EXPECT_EQ(segments(r.history).size(), 3u + 2 * 2);
  EXPECT_EQ(r.iterations, seg[6].last) << "the same path as the run without the round test, up to round 2";
}

// --schedule levels: the radius levels as in the paper schedule, then one
// phase with radii and rest shape together at the finest level, which is the
// rest of the run (no cap of its own, no alternation).
TEST(DesignSchedule, LevelsEndsWithOneJointPhaseThatIsTheRestOfTheRun) {
  const Scene scene = problem();
  SceneModel model(scene);
  const DesignSpace space(scene, model.effects());
  DesignOptimizerOptions o = baseOptions();
  o.schedule = Schedule::Levels;
  const std::vector<DesignStep> steps = designSchedule(scene, space, o);
  ASSERT_EQ(steps.size(), 4u);
  for (int l = 0; l < 3; ++l) {
    EXPECT_TRUE(steps[l].phase.radii && !steps[l].phase.restShape);
    EXPECT_EQ(steps[l].phase.level, l);
  }
  EXPECT_TRUE(steps[3].phase.radii && steps[3].phase.restShape);
  EXPECT_EQ(steps[3].phase.level, space.numLevels() - 1);
  EXPECT_EQ(steps[3].round, 0);

  o.maxLevelIterations = 3;
  o.maxPhaseIterations = 4;
  o.phaseRelativeDecrease = 0.0;
  o.maxIterations = 20;
  const DesignOptimizerResult r = optimize(o);
  const std::vector<Segment> seg = segments(r.history);
  ASSERT_EQ(seg.size(), 4u) << r.message;
  EXPECT_EQ(seg[3].phase, "joint");
  EXPECT_EQ(seg[3].iterations(), 20 - 3 * 3) << "the joint phase is not capped by maxPhaseIterations";
  EXPECT_LT(r.objective, r.initialObjective);

  // Without rest shape, levels is the paper schedule's radius levels.
  Scene radiiOnly = scene;
  radiiOnly.design.restShape = false;
  const std::vector<DesignStep> radii = designSchedule(radiiOnly, space, o);
  o.schedule = Schedule::Paper;
  const std::vector<DesignStep> paper = designSchedule(radiiOnly, space, o);
  ASSERT_EQ(radii.size(), paper.size());
  for (std::size_t i = 0; i < radii.size(); ++i) EXPECT_EQ(radii[i].phase.level, paper[i].phase.level);
}

TEST(DesignSchedule, RejectsBadScheduleLimits) {
  DesignOptimizerOptions o;
  EXPECT_EQ(o.isValid(), "");
  o.phaseWindow = 0;
  EXPECT_NE(o.isValid(), "");
  o = DesignOptimizerOptions{};
  o.phaseRelativeDecrease = 1.0;
  EXPECT_NE(o.isValid(), "");
  o = DesignOptimizerOptions{};
  o.roundRelativeDecrease = -0.1;
  EXPECT_NE(o.isValid(), "");
  o = DesignOptimizerOptions{};
  o.maxPhaseIterations = 0;
  EXPECT_NE(o.isValid(), "");
  o = DesignOptimizerOptions{};
  o.maxLevelIterations = 0;
  EXPECT_NE(o.isValid(), "");
}

}  // namespace
}  // namespace rodmesh
