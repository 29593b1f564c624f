// The stall rule (StallDetector) and the design monitor (solver/design_monitor.hh):
// a design is confirmed only when it re-solves from rest better than every
// design before it, on a thread of its own, and what it archives is what
// `rodmesh simulate` computes for that design.
#include "model/design_space.hh"
#include "solver/design_monitor.hh"
#include "solver/design_optimizer.hh"
#include "tests/testutil/design_problems.hh"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

namespace rodmesh {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(StallDetector, StallsWhenTheBestSettledObjectiveStopsFalling) {
  StallDetector s(5, 1e-3);
  s.add(1.0, true);
  for (int i = 0; i < 4; ++i) {
    s.add(1.0 - 1e-5 * (i + 1), true);  // 5e-5 over the window: less than 1e-3
    EXPECT_FALSE(s.stalled()) << "a window needs 5 iterates after its start, " << i + 1 << " so far";
  }
  s.add(1.0 - 5e-5, true);
  EXPECT_TRUE(s.stalled());
  EXPECT_NEAR(s.best(), 1.0 - 5e-5, 1e-15);
  s.add(0.99, true);  // 1 % below the window's start: progress again
  EXPECT_FALSE(s.stalled());
}

TEST(StallDetector, SteadyProgressIsNotAStall) {
  StallDetector s(5, 1e-3);
  double f = 1.0;
  for (int i = 0; i < 30; ++i) {
    s.add(f, true);
    EXPECT_FALSE(s.stalled()) << "iteration " << i;
    f *= 0.99;  // 5 % over a window
  }
}

TEST(StallDetector, AnExcursionAwayFromEquilibriumIsNotAStall) {
  // The optimizer leaves the constraints for a while (iterates not near
  // equilibrium, not settled): no decision until it is back for a whole window.
  StallDetector s(5, 1e-3);
  s.add(1.0, true);
  for (int i = 0; i < 10; ++i) {
    s.add(kInf, false);
    EXPECT_FALSE(s.stalled());
  }
  for (int i = 0; i < 4; ++i) {
    s.add(1.0, true);
    EXPECT_FALSE(s.stalled()) << "the window still holds iterates of the excursion";
  }
  s.add(1.0, true);
  EXPECT_TRUE(s.stalled());
}

TEST(StallDetector, IteratesNearButNotSettledCountForTheWindowButNotTheBest) {
  StallDetector s(3, 1e-3);
  s.add(1.0, true);
  s.add(kInf, true);
  s.add(kInf, true);
  s.add(kInf, true);
  EXPECT_TRUE(s.stalled()) << "near equilibrium throughout, no settled improvement";
  EXPECT_EQ(s.best(), 1.0);
}

TEST(StallDetector, ProgressSlowerThanTheMeaningfulRateIsAStall) {
  // Relative test off (0): only the gain against the initial design counts.
  // Initial objective 1 (RMS ~ 1): over a window of 3 iterations a gain of
  // 3 x kMeaningfulRmsPerIteration = 1.5e-5 in RMS is meaningful.
  ASSERT_DOUBLE_EQ(kMeaningfulRmsPerIteration, 5e-6);
  StallDetector s(3, 0.0, 1.0);
  s.add(0.01, true);  // RMS 0.1
  s.add(std::pow(0.1 - 4e-6, 2), true);
  s.add(std::pow(0.1 - 8e-6, 2), true);
  s.add(std::pow(0.1 - 1e-5, 2), true);
  EXPECT_TRUE(s.stalled());
  StallDetector t(3, 0.0, 1.0);
  t.add(0.01, true);
  t.add(std::pow(0.1 - 1e-5, 2), true);
  t.add(std::pow(0.1 - 2e-5, 2), true);
  t.add(std::pow(0.1 - 3e-5, 2), true);
  EXPECT_FALSE(t.stalled());
  EXPECT_TRUE(meaningfulGain(0.01, std::pow(0.1 - 2e-5, 2), 1.0, 3));
  EXPECT_FALSE(meaningfulGain(0.01, std::pow(0.1 - 1e-5, 2), 1.0, 3));
  // The threshold grows with the iterations spent: 1e-3 over 200.
  EXPECT_FALSE(meaningfulGain(0.01, std::pow(0.1 - 9e-4, 2), 1.0, 200));
  EXPECT_TRUE(meaningfulGain(0.01, std::pow(0.1 - 1.1e-3, 2), 1.0, 200));
  // ... and with the initial RMS (initial objective 4: RMS 2).
  EXPECT_FALSE(meaningfulGain(0.01, std::pow(0.1 - 1.1e-3, 2), 4.0, 200));
}

class DesignMonitorTest : public testing::Test {
 protected:
  void SetUp() override {
    problem_ = testutil::hiddenDesignSheet(true, true, 5, 2);
    model_ = std::make_unique<SceneModel>(problem_.scene);
    space_ = std::make_unique<DesignSpace>(problem_.scene, model_->effects());
    initial_ = space_->initialControls(problem_.scene);
    const Design d0 = space_->toDesign(initial_);
    const SimulationResult sim = simulateAll(*model_, d0, NewtonOptions{});
    ASSERT_TRUE(sim.allConverged);
    initialObjective_ = simulationObjective(problem_.scene, sim);
    ASSERT_GT(initialObjective_, 0.0);
  }
  // A design between the initial one and the hidden one: t = 0 initial, 1 hidden.
  ControlValues between(double t) const {
    const ControlValues& hidden = problem_.hidden;
    ControlValues c = initial_;
    c.radii = (1 - t) * initial_.radii + t * hidden.radii;
    c.displacement = (1 - t) * initial_.displacement + t * hidden.displacement;
    return c;
  }

  testutil::HiddenDesignProblem problem_;
  std::unique_ptr<SceneModel> model_;
  std::unique_ptr<DesignSpace> space_;
  ControlValues initial_;
  double initialObjective_ = 0.0;
};

TEST_F(DesignMonitorTest, ConfirmsOnlyDesignsThatReSolveFromRestBetterThanAllBefore) {
  std::vector<ConfirmedDesign> reported;
  std::mutex m;
  DesignMonitor monitor(problem_.scene, *space_, NewtonOptions{}, initialObjective_,
                        DesignMonitor::Clock::now(), [&](const ConfirmedDesign& c) {
                          std::lock_guard<std::mutex> lock(m);
                          reported.push_back(c);
                        });
  // The initial design is no improvement: reported once as the initial one.
  monitor.offer(initial_, 1, "initial again");
  monitor.drain();
  EXPECT_FALSE(monitor.best().has_value());
  // Half way to the hidden design: better.
  monitor.offer(between(0.5), 2, "half way");
  monitor.drain();
  ASSERT_TRUE(monitor.best().has_value());
  EXPECT_EQ(monitor.best()->iteration, 2);
  const double halfWay = monitor.best()->objective;
  EXPECT_LT(halfWay, initialObjective_);
  // A quarter of the way: worse than half way, not confirmed.
  monitor.offer(between(0.25), 3, "a quarter");
  monitor.drain();
  EXPECT_EQ(monitor.best()->iteration, 2);
  // The hidden design: the targets, to the solver's tolerance.
  monitor.offer(between(1.0), 4, "hidden");
  monitor.drain();
  ASSERT_TRUE(monitor.best().has_value());
  const ConfirmedDesign best = *monitor.best();
  EXPECT_EQ(best.iteration, 4);
  EXPECT_EQ(best.label, "hidden");
  EXPECT_LT(best.rms, 1e-3 * std::sqrt(2 * initialObjective_ / (2.0 * problem_.scene.vertices.size())));
  EXPECT_EQ(monitor.confirmed(), 2);
  EXPECT_EQ(monitor.checked(), 4);
  monitor.stop();
  // What it holds is what a solve from rest gives for that design (rodmesh
  // simulate), with its RMS and objective.
  const SimulationResult sim = simulateAll(*model_, best.design, NewtonOptions{});
  ASSERT_TRUE(sim.allConverged);
  for (std::size_t k = 0; k < sim.poses.size(); ++k)
    for (std::size_t v = 0; v < sim.poses[k].positions.size(); ++v)
      EXPECT_LT((sim.poses[k].positions[v] - best.simulation.poses[k].positions[v]).norm(), 1e-9);
  EXPECT_NEAR(best.rms, rmsError(sim), 1e-12);
  EXPECT_NEAR(best.objective, simulationObjective(problem_.scene, sim), 1e-15 + 1e-9 * best.objective);
  // Reported: the initial design first, then each new best.
  std::lock_guard<std::mutex> lock(m);
  ASSERT_EQ(reported.size(), 3u);
  EXPECT_TRUE(reported[0].initial);
  EXPECT_NEAR(reported[0].objective, initialObjective_, 1e-9 * initialObjective_);
  ASSERT_EQ(static_cast<int>(reported[0].states.size()), model_->numPoses());
  for (int k = 0; k < model_->numPoses(); ++k) {
    EXPECT_EQ(reported[0].states[k].loadFactor, 1.0);
    const std::vector<Vec3> x = model_->pose(k).positions(reported[0].states[k], reported[0].design);
    for (std::size_t v = 0; v < x.size(); ++v)
      EXPECT_LT((x[v] - reported[0].simulation.poses[k].positions[v]).norm(), 1e-12) << "pose " << k << " vertex " << v;
  }
  EXPECT_EQ(reported[1].iteration, 2);
  EXPECT_EQ(reported[2].iteration, 4);
}

// The states the monitor holds for a confirmed design are its loading
// path's (the simulation's own), the initial design's included.
TEST_F(DesignMonitorTest, ConfirmedStatesAreTheLoadingPathsEquilibria) {
  DesignMonitor monitor(problem_.scene, *space_, NewtonOptions{}, initialObjective_,
                        DesignMonitor::Clock::now());
  monitor.offer(between(0.5), 1, "half way");
  monitor.drain();
  ASSERT_TRUE(monitor.best().has_value()) << "the design re-solves from rest better than the initial one";
  EXPECT_EQ(monitor.best()->iteration, 1);
  {
    // Its states are the simulation's own (to
    // round-off: the positions are evaluated by another model of the scene).
    const std::optional<ConfirmedDesign> first = monitor.best();
    SceneModel model(problem_.scene);
    for (int k = 0; k < model.numPoses(); ++k) {
      EXPECT_EQ(first->states[k].loadFactor, 1.0);
      const std::vector<Vec3> x = model.pose(k).positions(first->states[k], first->design);
      ASSERT_EQ(x.size(), first->simulation.poses[k].positions.size());
      for (std::size_t v = 0; v < x.size(); ++v)
        EXPECT_LT((x[v] - first->simulation.poses[k].positions[v]).norm(), 1e-12) << "pose " << k << " vertex " << v;
    }
  }
  monitor.offer(between(1.0), 2, "hidden");
  monitor.drain();
  const std::optional<ConfirmedDesign> best = monitor.best();
  ASSERT_TRUE(best.has_value());
  EXPECT_EQ(best->iteration, 2);
  for (const PoseState& s : best->states) EXPECT_TRUE(s.u.allFinite());
  monitor.stop();
}

// Every offer is checked, however fast they come, and the best design once
// all were checked does not depend on the order of the checks (the newest is
// checked first): the design a run ends with must not depend on how far the
// monitor's thread got.
TEST_F(DesignMonitorTest, EveryOfferIsCheckedAndTheBestDoesNotDependOnTheOrder) {
  std::vector<int> reported;
  std::mutex m;
  DesignMonitor monitor(problem_.scene, *space_, NewtonOptions{}, initialObjective_,
                        DesignMonitor::Clock::now(), [&](const ConfirmedDesign& c) {
                          std::lock_guard<std::mutex> lock(m);
                          if (!c.initial) reported.push_back(c.iteration);
                        });
  // The best (t = 0.8) in the middle; offered without waiting.
  const double ts[] = {0.2, 0.4, 0.8, 0.6, 0.3};
  for (int i = 0; i < 5; ++i) monitor.offer(between(ts[i]), i + 1, "t = " + std::to_string(ts[i]));
  monitor.drain();
  EXPECT_EQ(monitor.checked(), 5);
  ASSERT_TRUE(monitor.best().has_value());
  EXPECT_EQ(monitor.best()->iteration, 3);
  // The same design offered again, later: an equal objective keeps the
  // earlier iteration, although the later offer may be checked first.
  monitor.offer(between(0.8), 9, "t = 0.8 again");
  monitor.offer(between(0.1), 10, "t = 0.1");
  monitor.drain();
  EXPECT_EQ(monitor.checked(), 7);
  EXPECT_EQ(monitor.best()->iteration, 3);
  monitor.stop();
  std::lock_guard<std::mutex> lock(m);
  ASSERT_FALSE(reported.empty());
  EXPECT_EQ(reported.back(), 3);
}

// The tie rule on its own: two offers of one design, queued while the
// monitor is busy, so that the later one is checked first.
TEST_F(DesignMonitorTest, OfEqualDesignsTheEarlierIterationIsKept) {
  DesignMonitor monitor(problem_.scene, *space_, NewtonOptions{}, initialObjective_,
                        DesignMonitor::Clock::now());
  for (int i = 1; i <= 6; ++i) monitor.offer(between(0.1 * i), i, "busy " + std::to_string(i));
  monitor.offer(between(1.0), 20, "hidden, first");
  monitor.offer(between(1.0), 30, "hidden, again");
  monitor.drain();
  ASSERT_TRUE(monitor.best().has_value());
  EXPECT_EQ(monitor.best()->iteration, 20);
  EXPECT_EQ(monitor.checked(), 8);
  monitor.stop();
}

TEST_F(DesignMonitorTest, ADrainGivesUpWhenAskedTo) {
  DesignMonitor monitor(problem_.scene, *space_, NewtonOptions{}, initialObjective_,
                        DesignMonitor::Clock::now());
  for (int i = 1; i <= 20; ++i) monitor.offer(between(0.05 * i), i, "offer " + std::to_string(i));
  EXPECT_FALSE(monitor.drain([] { return true; })) << "asked to give up at once, with checks queued";
  EXPECT_LT(monitor.checked(), 20);
  EXPECT_TRUE(monitor.drain([] { return false; }));
  EXPECT_EQ(monitor.checked(), 20);
  monitor.stop();
  EXPECT_FALSE(monitor.drain([] { return false; })) << "a stopped monitor checks nothing more";
}

TEST(ConfirmsIteration, TheFirstTenThenAboutEveryFifthPartMore) {
  for (int i = 1; i <= 10; ++i) EXPECT_TRUE(confirmsIteration(i)) << i;
  EXPECT_FALSE(confirmsIteration(0));
  EXPECT_FALSE(confirmsIteration(-3));
  std::vector<int> next;
  for (int i = 11; next.size() < 6; ++i)
    if (confirmsIteration(i)) next.push_back(i);
  EXPECT_EQ(next, (std::vector<int>{12, 14, 16, 19, 22, 26}));
  int count = 0, last = 0;
  for (int i = 1; i <= 2000; ++i) {
    if (!confirmsIteration(i)) continue;
    ++count;
    if (i > 10) {
      EXPECT_LE(i, static_cast<int>(1.2 * last) + 1) << "gap after " << last;
    }
    last = i;
  }
  EXPECT_GE(count, 35);
  EXPECT_LE(count, 45);
  EXPECT_GT(last, 1500) << "late iterations are still offered";
}

TEST_F(DesignMonitorTest, NonFiniteDesignsAreRejectedAndStopReturnsPromptly) {
  DesignMonitor monitor(problem_.scene, *space_, NewtonOptions{}, initialObjective_,
                        DesignMonitor::Clock::now());
  ControlValues bad = initial_;
  bad.radii(0, 0) = std::numeric_limits<double>::quiet_NaN();
  monitor.offer(bad, 1, "nan");
  monitor.drain();
  EXPECT_FALSE(monitor.best().has_value());
  EXPECT_EQ(monitor.checked(), 1);
  monitor.offer(between(1.0), 2, "hidden");
  const auto t0 = std::chrono::steady_clock::now();
  monitor.stop();  // abandons the check under way (Newton cancelled)
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  monitor.offer(between(1.0), 3, "after stop");  // ignored
  EXPECT_LE(monitor.checked(), 2);
}

}  // namespace
}  // namespace rodmesh
