// The one design driver (solver/design_driver.hh): what it does with the
// phase results of a scripted phase solver (phase ends, retries, failures,
// targets met, designs off the loading path), and what a real reduced run
// makes of a design problem whose optimizer equilibria leave the loading
// path (the shallow arch of testutil::invertibleArch).
#include "solver/design_driver.hh"

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <memory>

#include "model/design_space.hh"
#include "model/stiffness.hh"
#include "solver/design_fallback.hh"
#include "solver/design_monitor.hh"
#include "solver/design_optimizer.hh"
#include "tests/testutil/design_problems.hh"
#include "tests/testutil/scenes.hh"

namespace rodmesh {
namespace {

// A phase solver that returns what the test scripts, and records its tasks.
class ScriptedPhases : public PhaseSolver {
 public:
  std::function<PhaseResult(const PhaseTask&, PhaseContext&)> script;
  std::vector<PhaseTask> tasks;
  bool equilibria = true;  // false: like SAND, whose iterates are not equilibria
  bool onPath = false;     // can run a phase on the loading path (PhaseTask::onPath)
  bool iteratesAreEquilibria() const override { return equilibria; }
  bool solvesOnPath() const override { return onPath; }
  PhaseResult solvePhase(const PhaseTask& task, PhaseContext& context) override {
    tasks.push_back(task);
    return script(task, context);
  }
};

DesignOptimizerOptions driverOptions() {
  DesignOptimizerOptions o;
  o.confirmDesigns = false;  // deterministic: no second thread
  o.schedule = Schedule::Joint;
  return o;
}

// Scripted phases that propose design c with equilibrium `state` (of the
// scene's one pose) every time, after 5 iterations.
std::function<PhaseResult(const PhaseTask&, PhaseContext&)> proposing(const ControlValues& c, const PoseState& state) {
  return [c, state](const PhaseTask&, PhaseContext&) {
    PhaseResult r;
    r.iterations = 5;
    r.candidates.push_back({c, {state}});
    return r;
  };
}

// Targets of pose 0: the positions of `state` under d, 1 mm lower still, so
// that this equilibrium is much better than others but not exact.
void targetsBelow(Scene& s, const PoseSystem& sys, const PoseState& state, const Design& d) {
  s.poses[0].target = sys.positions(state, d);
  for (Vec3& x : s.poses[0].target) x.z() -= 1e-3;
}

// A cantilever whose targets come from a design with 0.6 times its radii.
struct Cantilever {
  Scene scene = testutil::fallbackCase();
  SceneModel model{scene};
  DesignSpace space{scene, model.effects()};
  ControlValues thinner(double scale) const {
    ControlValues c = space.initialControls(scene);
    c.radii *= scale;
    return c;
  }
  // Equilibria of `c` from rest.
  std::vector<PoseState> equilibria(const ControlValues& c) {
    const Design d = space.toDesign(c);
    std::vector<PoseState> s;
    for (int k = 0; k < model.numPoses(); ++k) s.push_back(model.pose(k).restState(d));
    EXPECT_TRUE(solvePosesFrom(model, d, s, NewtonOptions{}, 1));
    return s;
  }
};

TEST(DesignDriver, KeepsABetterCandidateAndNotAWorseOne) {
  Cantilever c;
  ScriptedPhases phases;
  const ControlValues better = c.thinner(0.8), worse = c.thinner(1.3);
  phases.script = [&](const PhaseTask&, PhaseContext&) {
    PhaseResult r;
    r.iterations = 3;
    // The worse one first: not kept; the better one is.
    r.candidates.push_back({worse, c.equilibria(worse)});
    r.candidates.push_back({better, c.equilibria(better)});
    return r;
  };
  const DesignOptimizerResult r = runDesign(c.model, c.space, driverOptions(), phases);
  ASSERT_EQ(phases.tasks.size(), 1u);
  EXPECT_EQ(r.outcome, Outcome::Converged) << r.message;
  EXPECT_TRUE(sameControls(r.controls, better));
  EXPECT_LT(r.objective, r.initialObjective);
  EXPECT_EQ(r.iterations, 3);
  ASSERT_EQ(r.fallbacks.size(), 1u) << "the kept design joins the fallbacks";
  // The run's summary: one finite equilibrium per pose at the full load, and
  // the largest force residual among them.
  EXPECT_TRUE(r.usable);
  ASSERT_EQ(static_cast<int>(r.states.size()), c.model.numPoses());
  double largest = 0.0;
  for (int k = 0; k < c.model.numPoses(); ++k) {
    Eigen::VectorXd g;
    c.model.pose(k).evaluate(r.states[k], r.design, &g, nullptr);
    largest = std::max(largest, c.model.pose(k).forceResidual(g).norm());
  }
  EXPECT_EQ(r.residualNorm, largest);
  EXPECT_LT(r.residualNorm, 1e-6);
  EXPECT_EQ(r.brief().rfind("converged after 3 iterations", 0), 0u) << r.brief();
}

TEST(DesignDriver, RetriesADivergedPhaseOnceThenStops) {
  Cantilever c;
  ScriptedPhases phases;
  phases.script = [&](const PhaseTask&, PhaseContext&) {
    PhaseResult r;
    r.end = PhaseEnd::Diverged;
    r.iterations = 2;
    return r;
  };
  const DesignOptimizerResult r = runDesign(c.model, c.space, driverOptions(), phases);
  ASSERT_EQ(phases.tasks.size(), 2u);
  EXPECT_EQ(phases.tasks[0].attempt, 0);
  EXPECT_EQ(phases.tasks[1].attempt, 1);
  EXPECT_FALSE(phases.tasks[0].diverged);
  EXPECT_TRUE(phases.tasks[1].diverged) << "the phase solver is told why the phase runs again";
  EXPECT_EQ(phases.tasks[1].iterationBase, 2);
  EXPECT_EQ(phases.tasks[1].index, 0) << "the retry is the same phase";
  EXPECT_EQ(r.outcome, Outcome::Stalled);
  EXPECT_NE(r.message.find("left equilibrium"), std::string::npos) << r.message;
  EXPECT_TRUE(sameControls(r.controls, c.space.initialControls(c.scene)));
}

// A phase whose iterates are no equilibria (SAND's) offers a design the
// monitor confirms from rest, then diverges without a candidate better than
// the start: the retry starts from the confirmed design, with its loading
// path's equilibria, not from the phase's start.
TEST(DesignDriver, ADivergedPhaseIsRunAgainFromTheBestDesignConfirmedFromRest) {
  Cantilever c;
  ScriptedPhases phases;
  phases.equilibria = false;
  const ControlValues better = c.thinner(0.8);
  phases.script = [&](const PhaseTask& task, PhaseContext& context) {
    PhaseResult r;
    r.iterations = 1;
    if (task.attempt == 0) {
      DesignIterate it;
      it.iteration = task.iterationBase + 1;
      context.iterate(it, &better, false, false);
      r.end = PhaseEnd::Diverged;
    }
    return r;
  };
  DesignOptimizerOptions o = driverOptions();
  o.confirmDesigns = true;
  const DesignOptimizerResult r = runDesign(c.model, c.space, o, phases);
  ASSERT_EQ(phases.tasks.size(), 2u) << r.message;
  EXPECT_TRUE(phases.tasks[1].diverged);
  EXPECT_TRUE(sameControls(phases.tasks[1].controls, better)) << "the retry starts from the confirmed design";
  // Its equilibria are the loading path's of that design.
  const std::vector<PoseState> path = c.equilibria(better);
  ASSERT_EQ(phases.tasks[1].states.size(), path.size());
  const Design d = c.space.toDesign(better);
  for (std::size_t k = 0; k < path.size(); ++k) {
    const std::vector<Vec3> x = c.model.pose(static_cast<int>(k)).positions(phases.tasks[1].states[k], d);
    const std::vector<Vec3> y = c.model.pose(static_cast<int>(k)).positions(path[k], d);
    for (std::size_t v = 0; v < x.size(); ++v) EXPECT_LT((x[v] - y[v]).norm(), 1e-9);
  }
  EXPECT_LT(phases.tasks[1].objective, r.initialObjective);
  EXPECT_TRUE(sameControls(r.controls, better));
  EXPECT_NE(r.message.find("confirmed from rest"), std::string::npos) << r.message;
}

// A clamped column (1 m, r = 1 cm, 20 edges) under twice its buckling load,
// radii free, targets 1 mm beside its straight (compressed) shape. The
// straight shape is an equilibrium, but an unstable one (one negative
// stiffness eigenvalue per bending plane); loaded from rest the column
// buckles, far from the targets.
struct CompressedColumn {
  static Scene make() {
    Scene s = testutil::cantilever(20, 1.0, 0.01, 0.01, Vec3(0, 0, 1));
    s.material = Material{1e8, 0.4, 500.0};
    s.effects = std::vector<Effect>{Effect::Stretch, Effect::Bend, Effect::Twist};
    const double EI = stiffness::bendingOut(s.material.youngModulus, 0.01, 0.01);
    s.poses[0].forces.push_back({20, Vec3(-2.0 * stiffness::kPi * stiffness::kPi * EI / 4.0, 0, 0)});
    for (const Vec3& x : s.vertices) s.poses[0].target.push_back(x + Vec3(0, 0, 1e-3));
    s.design.present = s.design.radii = true;
    s.design.hasRadiusBounds = true;
    s.design.radiusMin = 0.005;
    s.design.radiusMax = 0.02;
    return s;
  }
  Scene s = make();
  SceneModel model{s};
  DesignSpace space{s, model.effects()};
  // A design with radii scaled by `scale` and its straight equilibrium:
  // every edge shortened by P / (E A).
  std::pair<ControlValues, PoseState> straight(double scale) const {
    ControlValues c = space.initialControls(s);
    c.radii *= scale;
    const Design d = space.toDesign(c);
    const PoseSystem& sys = model.pose(0);
    const double r = 0.01 * scale, P = -s.poses[0].forces[0].force.x();
    const double strain = P / stiffness::stretching(s.material.youngModulus, r, r);
    std::vector<Vec3> x;
    for (const Vec3& v : s.vertices) x.push_back(v * (1.0 - strain));
    PoseState st = sys.restState(d);
    st.u = sys.dofsFrom(x, Eigen::VectorXd::Zero(static_cast<Eigen::Index>(s.vertices.size()) - 1));
    st.loadFactor = 1.0;
    return {c, st};
  }
};

// A phase solver whose iterates are not equilibria (SAND) can end at an
// unstable equilibrium: the equality constraint holds there too. Its polish
// lands on the buckled branch and the candidate is not kept; the driver runs
// the phase again the way it runs a diverged one, and says why. A phase
// solver whose iterates are equilibria has no such retry.
TEST(DesignDriver, APhaseEndingAtAnUnstableEquilibriumIsRunAgain) {
  const CompressedColumn col;
  const auto [c, straight] = col.straight(0.99);
  {
    Eigen::VectorXd g;
    col.model.pose(0).evaluate(straight, col.space.toDesign(c), &g, nullptr);
    ASSERT_LT(col.model.pose(0).forceResidual(g).norm(), 1e-9) << "the straight column is an equilibrium";
    const Stability st = stability(col.model.pose(0), col.space.toDesign(c), straight);
    ASSERT_TRUE(st.ok);
    ASSERT_EQ(st.negative, 2) << "an unstable one";
  }
  for (const bool equilibria : {false, true}) {
    ScriptedPhases phases;
    phases.equilibria = equilibria;
    phases.script = [&, c = c, straight = straight](const PhaseTask& task, PhaseContext&) {
      PhaseResult r;
      r.iterations = 5;
      if (task.attempt == 0) r.candidates.push_back({c, {straight}});
      return r;
    };
    const DesignOptimizerResult r = runDesign(col.model, col.space, driverOptions(), phases);
    if (equilibria) {
      EXPECT_EQ(phases.tasks.size(), 1u) << r.message;
      EXPECT_EQ(r.message.find("no stable equilibrium"), std::string::npos) << r.message;
      continue;
    }
    ASSERT_EQ(phases.tasks.size(), 2u) << r.message;
    EXPECT_TRUE(phases.tasks[1].diverged) << "run again by the method for diverged phases";
    EXPECT_EQ(phases.tasks[1].index, 0) << "the same phase";
    EXPECT_NE(r.message.find("is no stable equilibrium of its design: pose 'pose0' is an unstable equilibrium "
                             "there (2 negative stiffness eigenvalues)"),
              std::string::npos)
        << r.message;
    EXPECT_FALSE(sameControls(r.controls, c)) << "the unstable design is not the result";
  }
}

// A SAND-like phase whose final point (its first candidate) does worse than
// the best nearly feasible iterate it passed (the second, which the driver
// keeps): that design is no optimum of the phase, which is run again from
// it by the method for diverged phases. Not when the final point is the
// better one, nor for a phase solver whose iterates are equilibria.
TEST(DesignDriver, APhaseEndingWorseThanAnIterateItPassedIsRunAgain) {
  Cantilever c;
  const ControlValues passed = c.thinner(0.7), end = c.thinner(0.9);
  for (const bool equilibria : {false, true}) {
    for (const bool endFirst : {true, false}) {
      ScriptedPhases phases;
      phases.equilibria = equilibria;
      phases.script = [&](const PhaseTask& task, PhaseContext&) {
        PhaseResult r;
        r.iterations = 4;
        if (task.attempt == 0) {
          const ControlValues& first = endFirst ? end : passed;
          const ControlValues& second = endFirst ? passed : end;
          r.candidates.push_back({first, c.equilibria(first)});
          r.candidates.push_back({second, c.equilibria(second)});
        }
        return r;
      };
      const DesignOptimizerResult r = runDesign(c.model, c.space, driverOptions(), phases);
      const bool retried = !equilibria && endFirst;
      ASSERT_EQ(phases.tasks.size(), retried ? 2u : 1u) << equilibria << endFirst << ": " << r.message;
      EXPECT_TRUE(sameControls(r.controls, passed)) << "the better design is kept either way";
      if (!retried) {
        EXPECT_EQ(r.message.find("does worse than a design its iterates passed"), std::string::npos) << r.message;
        continue;
      }
      EXPECT_TRUE(phases.tasks[1].diverged) << "run again by the method for diverged phases";
      EXPECT_EQ(phases.tasks[1].index, 0) << "the same phase";
      EXPECT_TRUE(sameControls(phases.tasks[1].controls, passed)) << "from the design kept";
      EXPECT_NE(r.message.find("the optimum of radii level 2 (RMS "), std::string::npos) << r.message;
      EXPECT_NE(r.message.find("does worse than a design its iterates passed"), std::string::npos) << r.message;
    }
  }
}

TEST(DesignDriver, AFailedPhaseIsAFailedRunOnlyWithoutABetterDesign) {
  for (const bool improved : {false, true}) {
    Cantilever c;
    ScriptedPhases phases;
    phases.script = [&](const PhaseTask&, PhaseContext&) {
      PhaseResult r;
      r.end = PhaseEnd::Failed;
      r.message = "scripted failure";
      if (improved) r.candidates.push_back({c.thinner(0.8), c.equilibria(c.thinner(0.8))});
      return r;
    };
    const DesignOptimizerResult r = runDesign(c.model, c.space, driverOptions(), phases);
    EXPECT_EQ(r.outcome, improved ? Outcome::Stalled : Outcome::NumericalFailure) << r.message;
    EXPECT_EQ(r.message.find("scripted failure"), 0u) << r.message;
    EXPECT_EQ(r.message.find("was not kept") != std::string::npos, !improved) << r.message;
  }
}

TEST(DesignDriver, TargetsMetEndTheScheduleEarly) {
  Cantilever c;
  ScriptedPhases phases;
  DesignOptimizerOptions o = driverOptions();
  o.schedule = Schedule::Paper;  // radius levels: several phases
  const ControlValues hidden = c.thinner(0.6);  // the targets' design
  phases.script = [&](const PhaseTask& task, PhaseContext& ctx) {
    PhaseResult r;
    r.iterations = 1;
    DesignIterate it;
    it.iteration = task.iterationBase + 1;
    it.objective = 0.0;
    EXPECT_TRUE(ctx.iterate(it, &hidden, true, true)) << "an objective of 0 meets every target";
    r.end = PhaseEnd::TargetsMet;
    r.candidates.push_back({hidden, c.equilibria(hidden)});
    return r;
  };
  const DesignOptimizerResult r = runDesign(c.model, c.space, o, phases);
  ASSERT_GT(designSchedule(c.scene, c.space, o).size(), 1u);
  EXPECT_EQ(phases.tasks.size(), 1u);
  EXPECT_EQ(r.outcome, Outcome::Converged);
  EXPECT_EQ(r.message, "every target met to round-off");
  EXPECT_LT(r.objective, 1e-12 * r.initialObjective);
  EXPECT_EQ(r.history.size(), 2u) << "initial + the scripted iterate";
}

// An initial design whose equilibria are the targets up to round-off runs
// no phase (the optimizer would face a zero objective with undetermined
// multipliers); one a micrometre off still does.
TEST(DesignDriver, AnInitialDesignAtTheTargetsToRoundOffRunsNoPhase) {
  Cantilever c;
  const ControlValues initial = c.space.initialControls(c.scene);
  const Design d0 = c.space.toDesign(initial);
  const std::vector<PoseState> eq = c.equilibria(initial);
  for (const double offset : {1e-15, 1e-6}) {
    Scene s = c.scene;
    for (int k = 0; k < c.model.numPoses(); ++k) {
      s.poses[k].target = c.model.pose(k).positions(eq[k], d0);
      for (Vec3& x : s.poses[k].target) x += Vec3(offset, -offset, offset);
    }
    const SceneModel model(s);
    const DesignSpace space(s, model.effects());
    ScriptedPhases phases;
    phases.script = [&](const PhaseTask&, PhaseContext&) {
      PhaseResult r;
      r.end = PhaseEnd::Converged;
      return r;
    };
    const DesignOptimizerResult r = runDesign(model, space, driverOptions(), phases);
    EXPECT_EQ(r.outcome, Outcome::Converged) << offset << ": " << r.message;
    if (offset < 1e-9) {
      EXPECT_EQ(phases.tasks.size(), 0u);
      EXPECT_NE(r.message.find("meets every target to round-off"), std::string::npos) << r.message;
      EXPECT_EQ(r.history.size(), 1u) << "the initial design only";
    } else {
      EXPECT_GE(phases.tasks.size(), 1u) << r.message;
    }
  }
}

TEST(DesignDriver, LimitsStopBetweenPhases) {
  Cantilever c;
  ScriptedPhases phases;
  DesignOptimizerOptions o = driverOptions();
  o.schedule = Schedule::Paper;
  bool stop = false;
  o.stopRequested = [&] { return stop; };
  phases.script = [&](const PhaseTask&, PhaseContext& ctx) {
    PhaseResult r;
    r.iterations = 1;
    stop = true;  // a signal arrives during the first phase, which ends by its own test
    EXPECT_TRUE(ctx.limitReached());
    return r;
  };
  const DesignOptimizerResult r = runDesign(c.model, c.space, o, phases);
  EXPECT_EQ(phases.tasks.size(), 1u);
  EXPECT_EQ(r.outcome, Outcome::Interrupted);
}

// A phase whose design is the arch's own but whose equilibrium is the
// inverted one (what an optimizer holds after continuation across the snap):
// the loaded arch never reaches it. The driver notices at the phase end, runs
// the last phase again from the loading path's equilibrium (the arch up), and
// when the phase ends off the path a second time, the run is not converged
// and keeps the optimizer's equilibria, so that the archive marks the design
// off the path.
// The shallow arch of testutil::invertibleArch with targets 1 mm below its
// inverted equilibrium (targetsBelow): the scene's model, design space and
// initial design, that equilibrium, and the model of the targeted scene.
struct ArchTargetedInverted {
  explicit ArchTargetedInverted(bool restShape = false) : s(makeArch(restShape)), model(s), space(s, model.effects()) {
    c0 = space.initialControls(s);
    d0 = space.toDesign(c0);
    inverted = testutil::invertedArchState(s, model.pose(0), d0);
    targetsBelow(s, model.pose(0), inverted, d0);
    targeted = std::make_unique<SceneModel>(s);
  }
  static Scene makeArch(bool restShape) {
    Scene a = testutil::invertibleArch();
    a.design.restShape = restShape;
    return a;
  }
  Scene s;
  SceneModel model;
  DesignSpace space;
  ControlValues c0;
  Design d0;
  PoseState inverted;
  std::unique_ptr<SceneModel> targeted;
};

TEST(DesignDriver, APhaseEndOffTheLoadingPathContinuesFromThePath) {
  const ArchTargetedInverted arch;
  const DesignSpace& space = arch.space;
  const ControlValues& c0 = arch.c0;
  const Design& d0 = arch.d0;
  const PoseState& inverted = arch.inverted;
  const SceneModel& targeted = *arch.targeted;
  ASSERT_LT(arch.model.pose(0).positions(inverted, d0)[20].z(), -0.04);
  ScriptedPhases phases;
  phases.script = proposing(c0, inverted);
  const DesignOptimizerResult r = runDesign(targeted, space, driverOptions(), phases);
  ASSERT_EQ(phases.tasks.size(), 2u) << r.message;
  EXPECT_GT(phases.tasks[0].states[0].u.size(), 0);
  // The second attempt starts from the loading path's equilibrium: the arch up.
  const std::vector<Vec3> start = targeted.pose(0).positions(phases.tasks[1].states[0], d0);
  EXPECT_GT(start[20].z(), 0.0);
  const double invertedObjective = 0.5 * 41 * 1e-6;  // every vertex 1 mm off
  EXPECT_GT(phases.tasks[1].objective, 100 * invertedObjective) << "the path's objective, not the inverted one's";
  EXPECT_DOUBLE_EQ(r.objective, phases.tasks[1].objective) << "the result: the design with the path's equilibria";
  EXPECT_EQ(r.outcome, Outcome::Stalled);
  EXPECT_NE(r.message.find("off the loading path"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("as loaded from rest"), std::string::npos) << r.message;
  // The result's equilibria are the loading path's: the arch up.
  const std::vector<Vec3> own = targeted.pose(0).positions(r.states[0], d0);
  EXPECT_GT(own[20].z(), 0.0);
  const ArchivedDesign a = chooseArchivedDesign(targeted, space, r, NewtonOptions{});
  EXPECT_FALSE(a.offPath) << a.note;
}

// What the last resort's phases evaluate: with setFromRest, the reduced
// objective solves every pose from rest along its loading path (the arch
// stays up: `rodmesh simulate`'s objective), whatever the warm start (here
// the inverted branch, 1 mm from every target); without, it continues the
// warm start's branch.
TEST(DesignDriver, TheReducedObjectiveFromRestIsTheLoadedObjects) {
  const ArchTargetedInverted arch;
  const SceneModel& targeted = *arch.targeted;
  const TargetObjective objective(arch.s, targeted.effects());
  const DesignPhase phase{true, false, arch.space.numLevels() - 1};
  ReducedObjective ro(targeted, arch.space, objective, phase, arch.c0, NewtonOptions{}, 1, {arch.inverted});
  const Eigen::VectorXd z0 = arch.space.pack(phase, arch.c0);
  double warm = 0.0, fromRest = 0.0;
  Eigen::VectorXd g;
  ASSERT_TRUE(ro.evaluate(z0, warm, &g));
  EXPECT_NEAR(warm, 0.5 * 41 * 1e-6, 1e-3 * warm) << "the inverted branch, every vertex 1 mm off";
  ro.setFromRest(true);
  ASSERT_TRUE(ro.evaluate(z0, fromRest, &g));
  const SimulationResult sim = simulateAll(targeted, arch.d0, NewtonOptions{});
  ASSERT_TRUE(sim.allConverged);
  const double simulated = simulationObjective(arch.s, sim);
  EXPECT_GT(simulated, 100 * warm);
  EXPECT_NEAR(fromRest, simulated, 1e-9 * simulated);
  EXPECT_TRUE(g.allFinite());
  EXPECT_GT(ro.statesAt(z0)->at(0).u.size(), 0);
  EXPECT_GT(targeted.pose(0).positions(ro.statesAt(z0)->at(0), arch.d0)[20].z(), 0.0) << "the arch up";
}

// A solver that can run a phase on the loading path gets one more run of the
// last phase when it ended off the path twice: from the design that does
// best as loaded from rest, with that design's loading-path equilibria, and
// the task says so. A design it proposes there is on its path (here: a
// thinner arch, with its equilibria from rest), and the run is converged.
TEST(DesignDriver, ALastPhaseOffThePathTwiceIsRunOnThePath) {
  const ArchTargetedInverted arch;
  const DesignSpace& space = arch.space;
  const ControlValues& c0 = arch.c0;
  const SceneModel& targeted = *arch.targeted;
  ControlValues thin = c0;
  thin.radii *= 0.7;
  const Design dThin = space.toDesign(thin);
  std::vector<PoseState> fromRest{targeted.pose(0).restState(dThin)};
  ASSERT_TRUE(solvePosesFrom(targeted, dThin, fromRest, NewtonOptions{}, 1));
  ScriptedPhases phases;
  phases.onPath = true;
  phases.script = [&](const PhaseTask& task, PhaseContext&) {
    PhaseResult r;
    r.iterations = 5;
    r.candidates.push_back(task.onPath ? PhaseCandidate{thin, fromRest} : PhaseCandidate{c0, {arch.inverted}});
    return r;
  };
  const DesignOptimizerResult r = runDesign(targeted, space, driverOptions(), phases);
  ASSERT_EQ(phases.tasks.size(), 3u) << r.message;
  EXPECT_FALSE(phases.tasks[0].onPath);
  EXPECT_FALSE(phases.tasks[1].onPath);
  EXPECT_TRUE(phases.tasks[2].onPath);
  // It starts from the best design on its path (the initial arch, up), with
  // the loading path's equilibrium.
  EXPECT_TRUE(sameControls(phases.tasks[2].controls, c0));
  EXPECT_GT(targeted.pose(0).positions(phases.tasks[2].states[0], arch.d0)[20].z(), 0.0);
  EXPECT_EQ(r.outcome, Outcome::Converged) << r.message;
  EXPECT_TRUE(sameControls(r.controls, thin)) << r.message;
  EXPECT_NE(r.message.find("every equilibrium solved from rest along its loading path"), std::string::npos)
      << r.message;
  const ArchivedDesign a = chooseArchivedDesign(targeted, space, r, NewtonOptions{});
  EXPECT_FALSE(a.offPath) << a.note;
  EXPECT_NEAR(a.rms, r.rms, 1e-9);
  EXPECT_LT(r.objective, r.initialObjective);
}

// The same with the rest shape free: the driver displaces the rest shape
// towards the designed (inverted) branch until the arch, loaded from rest,
// snaps through onto it (a shallower arch has a lower limit load), and the
// run goes on from that design, on its loading path: the last phase is run
// again from it. (The scripted phase proposes the same off-path design
// again; the result is then the best design on its loading path, stalled.)
TEST(DesignDriver, ARestShapeSeededTowardsTheDesignedBranchBringsThePathOntoIt) {
  const ArchTargetedInverted arch(/*restShape=*/true);
  const DesignSpace& space = arch.space;
  const ControlValues& c0 = arch.c0;
  const Design& d0 = arch.d0;
  const PoseState& inverted = arch.inverted;
  const SceneModel& targeted = *arch.targeted;
  ScriptedPhases phases;
  phases.script = proposing(c0, inverted);
  // From the scene's rest shape (the target's rest shape, an inverted arch,
  // would be the start otherwise: see the next test).
  DesignOptimizerOptions o = driverOptions();
  o.startFromTargets = false;
  const DesignOptimizerResult r = runDesign(targeted, space, o, phases);
  ASSERT_EQ(phases.tasks.size(), 2u) << r.message;
  EXPECT_NE(r.message.find("rest shape displaced by"), std::string::npos) << r.message;
  // The retry starts from the seeded design, with its path's (inverted) equilibria.
  EXPECT_FALSE(sameControls(phases.tasks[1].controls, c0));
  const Design seeded = space.toDesign(phases.tasks[1].controls);
  EXPECT_LT(targeted.pose(0).positions(phases.tasks[1].states[0], seeded)[20].z(), -0.01);
  EXPECT_EQ(r.outcome, Outcome::Stalled) << r.message;
  // The result: a shallower rest shape whose loading path ends inverted
  // (shallower than the targets: the phases that follow in a real run work
  // from there), with those equilibria; three times closer to the targets
  // than the initial design as loaded from rest (23 against 72 mm).
  EXPECT_FALSE(sameControls(r.controls, c0));
  const Design d = space.toDesign(r.controls);
  EXPECT_LT(d.restPositions[20].z(), d0.restPositions[20].z());
  EXPECT_GT(d.restPositions[20].z(), 0.0) << "still an arch at rest";
  EXPECT_LT(targeted.pose(0).positions(r.states[0], d)[20].z(), -0.01);
  EXPECT_LT(r.rms, 0.5 * r.initialRms) << r.message;
  const ArchivedDesign a = chooseArchivedDesign(targeted, space, r, NewtonOptions{});
  EXPECT_FALSE(a.offPath) << a.note;
  EXPECT_NEAR(a.rms, r.rms, 1e-9);
}

// The same arch with the rest shape free: the rest shape in which the
// target (below the inverted arch) is unloaded, fitted by the control
// points, is an inverted arch whose loading path stays inverted, far closer
// to the target than the scene's arch, which stays up. The first phase
// starts there; the initial design is still the scene's.
TEST(DesignDriver, TheRestShapeOfATargetThatHalvesTheObjectiveIsTheStart) {
  const ArchTargetedInverted arch(/*restShape=*/true);
  const SceneModel& targeted = *arch.targeted;
  ScriptedPhases phases;
  phases.script = [](const PhaseTask& task, PhaseContext&) {
    PhaseResult r;
    r.iterations = 1;
    r.candidates.push_back({task.controls, task.states});
    return r;
  };
  const DesignOptimizerResult r = runDesign(targeted, arch.space, driverOptions(), phases);
  ASSERT_EQ(phases.tasks.size(), 1u) << r.message;
  EXPECT_NE(r.message.find("the run started from the rest shape of pose"), std::string::npos) << r.message;
  const Design start = arch.space.toDesign(phases.tasks[0].controls);
  EXPECT_LT(start.restPositions[20].z(), -0.01) << "an inverted arch at rest";
  EXPECT_LT(targeted.pose(0).positions(phases.tasks[0].states[0], start)[20].z(), -0.01);
  EXPECT_LT(phases.tasks[0].objective, 0.5 * r.initialObjective);
  // The initial design's RMS is the scene's arch, loaded from rest.
  double f0 = 0.0;
  std::vector<PoseState> rest{targeted.pose(0).restState(arch.d0)};
  ASSERT_TRUE(solvePosesFrom(targeted, arch.d0, rest, NewtonOptions{}, 1));
  TargetObjective objective(arch.s, targeted.effects());
  objectiveOfStates(targeted, objective, arch.d0, rest, f0);
  EXPECT_NEAR(r.initialObjective, f0, 1e-9 * f0);
  EXPECT_LT(r.rms, 0.5 * r.initialRms);
  // Off, the scene's arch is the start.
  DesignOptimizerOptions o = driverOptions();
  o.startFromTargets = false;
  ScriptedPhases again;
  again.script = phases.script;
  const DesignOptimizerResult s = runDesign(targeted, arch.space, o, again);
  ASSERT_EQ(again.tasks.size(), 1u) << s.message;
  EXPECT_TRUE(sameControls(again.tasks[0].controls, arch.c0));
  EXPECT_EQ(s.message.find("the run started from"), std::string::npos) << s.message;
}

// The arch with its targets on the initial design's inverted branch, and a
// thicker arch with its inverted equilibrium: a design the optimizer may
// hold there, which loaded from rest stays up, farther from the targets.
struct ThickArchTargetedInverted {
  explicit ThickArchTargetedInverted(bool restShape = false)
      : s(makeScene(restShape)), targeted(s), space(s, targeted.effects()) {
    c0 = space.initialControls(s);
    thick = c0;
    thick.radii *= 1.2;
    inverted = testutil::invertedArchState(s, targeted.pose(0), space.toDesign(thick));
  }
  static Scene makeScene(bool restShape) {
    Scene a = testutil::invertibleArch();
    a.design.restShape = restShape;
    SceneModel model(a);
    const DesignSpace space(a, model.effects());
    const Design d0 = space.toDesign(space.initialControls(a));
    a.poses[0].target = model.pose(0).positions(testutil::invertedArchState(a, model.pose(0), d0), d0);
    return a;
  }
  Scene s;
  SceneModel targeted;
  DesignSpace space;
  ControlValues c0, thick;
  PoseState inverted;
};

// A run that went on from the loading path's equilibria and found nothing
// better there ends with the best design whose equilibria are its loading
// path's: here the initial design, as the thicker arch the phase proposed
// (its inverted equilibrium near the targets) stays up when loaded from rest,
// farther from the inverted targets than the initial arch. The run is not
// converged: the archived equilibria are not the ones it ended at.
TEST(DesignDriver, ARunWorseOnThePathThanItsStartKeepsTheStart) {
  const ThickArchTargetedInverted arch;
  const SceneModel& targeted = arch.targeted;
  const DesignSpace& space = arch.space;
  const ControlValues& c0 = arch.c0;
  const ControlValues& thick = arch.thick;
  const PoseState& inverted = arch.inverted;
  ASSERT_LT(targeted.pose(0).positions(inverted, space.toDesign(thick))[20].z(), -0.04);
  ScriptedPhases phases;
  phases.script = [&](const PhaseTask& task, PhaseContext&) {
    PhaseResult r;
    r.iterations = 5;
    if (task.attempt == 0) r.candidates.push_back({thick, {inverted}});  // the retry finds nothing better
    return r;
  };
  const DesignOptimizerResult r = runDesign(targeted, space, driverOptions(), phases);
  ASSERT_EQ(phases.tasks.size(), 2u) << r.message;
  ASSERT_GT(phases.tasks[1].objective, r.initialObjective)
      << "the thick arch from rest must be worse than the initial one for this test";
  EXPECT_EQ(r.outcome, Outcome::Stalled) << r.message;
  EXPECT_TRUE(sameControls(r.controls, c0)) << r.message;
  EXPECT_DOUBLE_EQ(r.objective, r.initialObjective);
  EXPECT_NE(r.message.find("worse than the initial design"), std::string::npos) << r.message;
  const ArchivedDesign a = chooseArchivedDesign(targeted, space, r, NewtonOptions{});
  EXPECT_FALSE(a.offPath) << a.note;
  EXPECT_NEAR(a.rms, r.initialRms, 1e-9);
}

// The same run with a solver that can run a phase on the loading path: the
// last phase is run once more from the initial design, on the path, instead
// of ending stalled; finding nothing better there, the run is converged with
// the initial design, whose archived equilibria are the ones it ended at.
TEST(DesignDriver, ALastPhaseWorseOnThePathThanItsStartIsRunOnThePath) {
  const ThickArchTargetedInverted arch;
  const SceneModel& targeted = arch.targeted;
  const DesignSpace& space = arch.space;
  const ControlValues& c0 = arch.c0;
  const ControlValues& thick = arch.thick;
  const PoseState& inverted = arch.inverted;
  ScriptedPhases phases;
  phases.onPath = true;
  phases.script = [&](const PhaseTask& task, PhaseContext&) {
    PhaseResult r;
    r.iterations = 5;
    if (task.attempt == 0) r.candidates.push_back({thick, {inverted}});
    return r;
  };
  const DesignOptimizerResult r = runDesign(targeted, space, driverOptions(), phases);
  ASSERT_EQ(phases.tasks.size(), 3u) << r.message;
  EXPECT_FALSE(phases.tasks[1].onPath);
  EXPECT_TRUE(phases.tasks[2].onPath);
  EXPECT_TRUE(sameControls(phases.tasks[2].controls, c0));
  EXPECT_DOUBLE_EQ(phases.tasks[2].objective, r.initialObjective);
  EXPECT_EQ(r.outcome, Outcome::Converged) << r.message;
  EXPECT_TRUE(sameControls(r.controls, c0)) << r.message;
  EXPECT_NE(r.message.find("is worse than the initial design"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("a last phase was run from that design, every equilibrium solved from rest"),
            std::string::npos)
      << r.message;
  const ArchivedDesign a = chooseArchivedDesign(targeted, space, r, NewtonOptions{});
  EXPECT_FALSE(a.offPath) << a.note;
  EXPECT_NEAR(a.rms, r.initialRms, 1e-9);
}

// The alternation's round test ending such a run (the reduced method's
// schedule): a joint phase at the finest level on the path from the better
// design, not the end. The arch with radii and rest shape free; round 1's
// rest-shape phase proposes the thick arch inverted (off its path: loaded
// from rest it stays up), the phases after it nothing.
TEST(DesignDriver, AnAlternationEndingWorseOnThePathEndsWithAJointPhaseOnThePath) {
  const ThickArchTargetedInverted arch(/*restShape=*/true);
  const SceneModel& targeted = arch.targeted;
  const DesignSpace& space = arch.space;
  const ControlValues& thick = arch.thick;
  const PoseState& inverted = arch.inverted;
  ScriptedPhases phases;
  phases.onPath = true;
  phases.script = [&](const PhaseTask& task, PhaseContext&) {
    PhaseResult r;
    r.iterations = 5;
    if (task.step.round == 1 && task.step.phase.restShape && task.attempt == 0)
      r.candidates.push_back({thick, {inverted}});
    return r;
  };
  DesignOptimizerOptions options = driverOptions();
  options.schedule = Schedule::Paper;
  const DesignOptimizerResult r = runDesign(targeted, space, options, phases);
  ASSERT_GE(phases.tasks.size(), 2u) << r.message;
  const PhaseTask& last = phases.tasks.back();
  EXPECT_TRUE(last.onPath) << r.message;
  EXPECT_TRUE(last.step.phase.radii && last.step.phase.restShape) << "a joint phase";
  EXPECT_EQ(last.step.phase.level, space.numLevels() - 1);
  for (std::size_t i = 0; i + 1 < phases.tasks.size(); ++i) EXPECT_FALSE(phases.tasks[i].onPath) << i;
  EXPECT_NE(r.message.find("a last phase was run from that design"), std::string::npos) << r.message;
  EXPECT_EQ(r.outcome, Outcome::Converged) << r.message;
  EXPECT_LE(r.objective, r.initialObjective);
  const ArchivedDesign a = chooseArchivedDesign(targeted, space, r, NewtonOptions{});
  EXPECT_FALSE(a.offPath) << a.note;
  EXPECT_NEAR(a.rms, r.rms, 1e-9);
}

// A run that went on from the loading path and whose last phase ends on its
// path, with a design better than any before, is converged with that design:
// the best design on its path is then the last design itself, whatever the
// objectives of its two equilibria (the optimizer's and the loading path's,
// equal to the solver's tolerance) say. The phase proposes the initial arch
// inverted (off its path), then thinner arches with an equilibrium under
// 1.0005 times the load: within the driver's tolerance, farther from the
// targets than the loading path's equilibrium.
TEST(DesignDriver, ARunThatWentOnFromThePathAndEndsOnItIsConverged) {
  const ArchTargetedInverted arch;
  const DesignSpace& space = arch.space;
  const ControlValues& c0 = arch.c0;
  const PoseState& inverted = arch.inverted;
  const SceneModel& targeted = *arch.targeted;
  Scene heavier = arch.s;
  heavier.poses[0].forces[0].force *= 1.0005;
  const SceneModel heavierModel(heavier);
  DesignOptimizerOptions options = driverOptions();
  options.newton.tolerance = 1e-3;
  NewtonOptions tight;
  tight.tolerance = 1e-12;
  for (const double scale : {0.6, 0.7, 0.75}) {
    ControlValues thin = c0;
    thin.radii *= scale;
    const Design d = space.toDesign(thin);
    std::vector<PoseState> early{heavierModel.pose(0).restState(d)};
    ASSERT_TRUE(solvePosesFrom(heavierModel, d, early, tight, 1));
    ASSERT_LT(heavierModel.pose(0).positions(early[0], d)[20].z(), -0.04) << "the thin arch snaps through from rest";
    ScriptedPhases phases;
    phases.script = [&](const PhaseTask& task, PhaseContext&) {
      PhaseResult r;
      r.iterations = 5;
      r.candidates.push_back(task.attempt == 0 ? PhaseCandidate{c0, {inverted}} : PhaseCandidate{thin, early});
      return r;
    };
    const DesignOptimizerResult r = runDesign(targeted, space, options, phases);
    ASSERT_EQ(phases.tasks.size(), 2u) << r.message;
    EXPECT_TRUE(sameControls(r.controls, thin)) << "radii x " << scale << ": " << r.message;
    EXPECT_EQ(r.outcome, Outcome::Converged) << "radii x " << scale << ": " << r.message;
    EXPECT_EQ(r.message.find("is worse than"), std::string::npos) << r.message;
  }
}

// The same targets with a real reduced run, radii free in [4, 6] mm: at
// 4 mm the arch's limit load is below 0.2 N (EI ~ r^4: 0.41 x 0.44 N), so
// thin designs snap through when loaded from rest. Whatever branch the
// optimizer follows, a converged run's equilibria are its loading path's,
// and the design archived re-solves from rest on the inverted side.
TEST(DesignDriver, ReducedRunOnTheArchEndsOnTheLoadingPath) {
  Scene s = testutil::invertibleArch();
  {
    SceneModel model(s);
    const DesignSpace space(s, model.effects());
    const Design d0 = space.toDesign(space.initialControls(s));
    const PoseState inverted = testutil::invertedArchState(s, model.pose(0), d0);
    s.poses[0].target = model.pose(0).positions(inverted, d0);
  }
  SceneModel model(s);
  const DesignSpace space(s, model.effects());
  DesignOptimizerOptions o;
  o.confirmDesigns = false;
  const DesignOptimizerResult r = optimizeReduced(model, space, o);
  const ArchivedDesign a = chooseArchivedDesign(model, space, r, NewtonOptions{});
  ASSERT_TRUE(a.allConverged);
  if (r.outcome == Outcome::Converged) {
    EXPECT_FALSE(a.offPath) << r.message << "; " << a.note;
  }
  EXPECT_LT(a.simulation.poses[0].positions[20].z(), 0.0) << r.message << "; " << a.note;
  EXPECT_LT(a.rms, 0.2 * r.initialRms) << r.message << "; " << a.note;
  std::printf("arch, reduced: %s, %s; archived RMS %.3g mm (initial %.3g mm)\n", outcomeName(r.outcome),
              r.message.c_str(), a.rms * 1e3, r.initialRms * 1e3);
}

}  // namespace
}  // namespace rodmesh
