// The work of `rodmesh optimize` (apps/cmd_optimize.cc), shared with the
// Python module (python/): options, their checks, and the run that builds
// the archive.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <thread>

#include "apps/cli_common.hh"
#include "apps/flag_checks.hh"
#include "apps/run.hh"
#include "solver/design_fallback.hh"
#include "solver/design_optimizer.hh"
#include "solver/minimizer.hh"
#ifdef RODMESH_HAVE_NLP
#include "nlp/sand.hh"
#endif

namespace rodmesh::cli {

namespace {

bool sandAvailable() {
#ifdef RODMESH_HAVE_NLP
  return true;
#else
  return false;
#endif
}

}  // namespace

int defaultOptimizeThreads() {
  const unsigned n = std::thread::hardware_concurrency();  // 0: unknown
  return n == 0 ? 1 : static_cast<int>(std::min<unsigned>(n, static_cast<unsigned>(kMaxThreads)));
}

void checkOptimizeOptions(OptimizeOptions& o) {
  o.optimizer.imperfectionBackOff = !o.noImperfectionBackOff;
  o.optimizer.startFromTargets = !o.sceneStart;
  if (o.method.empty()) o.method = sandAvailable() ? "sand" : "reduced";
  if (o.method == "sand" && !sandAvailable())
    throw InputError("optimize: --method sand: the Ipopt optimizer is not part of this build; use --method reduced");
  if (!o.designDerivatives.empty() && o.designDerivatives != "exact" && o.method != "reduced")
    throw InputError("optimize: --design-derivatives " + o.designDerivatives +
                     " applies to --method reduced only (--method " + o.method + " uses exact derivatives)");
  o.optimizer.designDerivatives = o.designDerivatives == "fd"           ? DesignDerivatives::FiniteDifference
                                  : o.designDerivatives == "fd-resolve" ? DesignDerivatives::FiniteDifferenceResolve
                                                                        : DesignDerivatives::Exact;
  if (!o.ipopt.empty() && o.method != "sand")
    throw InputError("optimize: --ipopt applies to --method sand only, got --ipopt " + o.ipopt.front());
  if (o.optimizer.maxIterations < 0)
    throw InputError("optimize: --max-iter must be non-negative, got " + std::to_string(o.optimizer.maxIterations));
  if (!(o.optimizer.timeLimit >= 0) || !std::isfinite(o.optimizer.timeLimit))
    throw InputError("optimize: --time-limit must be a non-negative number of seconds, got " +
                     std::to_string(o.optimizer.timeLimit));
  if (!(o.optimizer.tolerance > 0 && o.optimizer.tolerance < 1))
    throw InputError("optimize: --tol must lie in (0, 1), got " + std::to_string(o.optimizer.tolerance));
  if (o.optimizer.threads < 1 || o.optimizer.threads > 256)
    throw InputError("optimize: --threads must lie in [1, 256], got " + std::to_string(o.optimizer.threads));
  for (const std::string& kv : o.ipopt) {
    const std::size_t eq = kv.find('=');
    if (eq == std::string::npos || eq == 0)
      throw InputError("optimize: --ipopt takes KEY=VALUE, got '" + kv + "'");
#ifdef RODMESH_HAVE_NLP
    if (std::string why = checkIpoptOption(kv.substr(0, eq), kv.substr(eq + 1)); !why.empty())
      throw InputError("optimize: --ipopt " + kv + ": " + why);
#endif
  }
#ifdef RODMESH_HAVE_NLP
  if (o.method == "sand")
    if (std::string why = checkIpoptOptionsFile(); !why.empty()) throw InputError("optimize: " + why);
#endif
  // Each method's default schedule (docs/optimization.md, "Defaults"): the
  // paper's for the paper's method, everything at once for the others.
  if (o.schedule.empty()) o.schedule = o.method == "reduced" ? "paper" : "joint";
  o.optimizer.schedule = o.schedule == "joint"        ? Schedule::Joint
                         : o.schedule == "levels"     ? Schedule::Levels
                         : o.schedule == "multilevel" ? Schedule::Multilevel
                                                      : Schedule::Paper;
  if (std::string why = o.optimizer.isValid(); !why.empty()) throw InputError("optimize: " + why);
}

namespace {
// A run from the scene's rest shape that ends above this fraction of the
// initial design's RMS has not met its targets: a second start is tried.
constexpr double kSecondStartRms = 0.01;
// At most this many runs more for a scene without normals whose design's
// equilibria move with the normals derived from its rest shape.
constexpr int kNormalsRounds = 3;

// Adds the cost of another run (time, evaluations) to `into`'s.
void addRunCost(DesignOptimizerResult& into, const DesignOptimizerResult& other) {
  into.timeSeconds += other.timeSeconds;
  into.evaluationSeconds += other.evaluationSeconds;
  into.solverSeconds += other.solverSeconds;
  into.evaluations += other.evaluations;
}

// The largest distance between the same vertex of the same pose in two
// simulations of one scene.
double largestDistance(const SimulationResult& a, const SimulationResult& b) {
  double gap = 0.0;
  for (std::size_t p = 0; p < a.poses.size() && p < b.poses.size(); ++p)
    for (std::size_t v = 0; v < a.poses[p].positions.size() && v < b.poses[p].positions.size(); ++v)
      gap = std::max(gap, (a.poses[p].positions[v] - b.poses[p].positions[v]).norm());
  return gap;
}
}  // namespace

OptimizeRun runOptimize(const Scene& scene, const SceneModel& model, const DesignSpace& space, OptimizeOptions& o,
                        const DesignProgress& progress, bool quiet) {
  auto optimizeOn = [&](const SceneModel& m, const DesignSpace& sp, const DesignOptimizerOptions& opt,
                        const DesignProgress& prog) {
#ifdef RODMESH_HAVE_NLP
    if (o.method == "sand") {
      SandOptions so;
      so.optimizer = opt;
      for (const std::string& kv : o.ipopt) {
        const std::size_t eq = kv.find('=');
        so.ipopt.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
      }
      return optimizeSand(m, sp, so, prog);
    }
#endif
    return o.method == "newton" ? optimizeNewton(m, sp, opt, prog) : optimizeReduced(m, sp, opt, prog);
  };
  auto optimizeWith = [&](const DesignOptimizerOptions& opt) { return optimizeOn(model, space, opt, progress); };
  // Where a second start may follow (below), each run leaves its
  // imperfection back-off (DesignOptimizerOptions::imperfectionBackOff) to
  // this function, which runs it on the run it keeps only: the back-off
  // solves every pose from rest several times, and a run that is not kept
  // need not pay for it. `spent`: the time the runs took so far, which
  // --time-limit covers too.
  auto backOff = [&](DesignOptimizerResult& run, double spent) {
    DesignOptimizerOptions opt = o.optimizer;
    if (opt.timeLimit > 0) opt.timeLimit = std::max(1e-9, opt.timeLimit - spent);
    completeImperfectionBackOff(model, space, opt, run);
  };
  DesignOptimizerOptions first = o.optimizer;
  first.deferImperfectionBackOff =
      o.optimizer.imperfectionBackOff && o.optimizer.startFromTargets && scene.design.restShape;
  DesignOptimizerResult r = optimizeWith(first);
  // A second start (docs/optimization.md, "A second start"): with the rest
  // shape free, a run from the scene's rest shape that ended by its own
  // tests with the targets not met (RMS above kSecondStartRms of the initial
  // design's) is followed by a run from the best target's rest shape that
  // does better from rest than the initial design, and the better of the
  // two is the result.
  if (o.optimizer.startFromTargets && scene.design.restShape && r.start.empty() && !r.startCandidate.empty() &&
      (r.outcome == Outcome::Converged || r.outcome == Outcome::Stalled) && r.initialRms > 0 &&
      r.rms > kSecondStartRms * r.initialRms) {
    DesignOptimizerOptions second = first;
    second.startTargetPose = r.startCandidatePose;
    bool timeLeft = true;  // --time-limit covers both runs
    if (second.timeLimit > 0) {
      second.timeLimit -= r.timeSeconds;
      timeLeft = second.timeLimit > 1e-3;
    }
    if (timeLeft) {
      if (!quiet)
        std::fprintf(stderr,
                     "optimizer: %s (RMS %.4f mm, %.3g of the initial design's): a second run from %s\n",
                     outcomeName(r.outcome), r.rms * 1e3, r.rms / r.initialRms, r.startCandidate.c_str());
      DesignOptimizerResult r2 = optimizeWith(second);
      // The second run's design replaces the first's when it is better and
      // its run ended as well (a converged first run is not traded for a
      // second one cut by the time limit). Judged before the back-off, then
      // again after it when backing off made the better one worse than the
      // other (then backed off too).
      const bool endedAsWell = r2.outcome == Outcome::Converged || r.outcome != Outcome::Converged;
      const bool secondCounts = !r2.start.empty() && r2.outcome != Outcome::InvalidProblem &&
                                r2.outcome != Outcome::NumericalFailure && r2.usable && endedAsWell;
      bool secondWins = secondCounts && r2.rms < r.rms;
      DesignOptimizerResult& winner = secondWins ? r2 : r;
      DesignOptimizerResult& loser = secondWins ? r : r2;
      const double loserRms = loser.rms;
      backOff(winner, r.timeSeconds + r2.timeSeconds);
      if (secondCounts && winner.rms > loserRms) {
        backOff(loser, r.timeSeconds + r2.timeSeconds);  // (the winner's back-off included)
        secondWins = secondCounts && r2.rms < r.rms;
      }
      char buf[200];
      if (secondWins)
        std::snprintf(buf, sizeof buf, "; a second run, from %s (RMS %.4f mm) is the result, against %.4f mm from the "
                      "scene's rest shape", r2.start.c_str(), r2.rms * 1e3, r.rms * 1e3);
      else
        std::snprintf(buf, sizeof buf, "; a second run, from %s, ended at RMS %.4f mm (%s), not better: the first "
                      "run's design is the result", r.startCandidate.c_str(), r2.rms * 1e3, outcomeName(r2.outcome));
      DesignOptimizerResult& kept = secondWins ? r2 : r;
      const DesignOptimizerResult& other = secondWins ? r : r2;
      kept.message += buf;
      addRunCost(kept, other);
      if (secondWins) r = std::move(r2);
    }
  }
  backOff(r, r.timeSeconds);  // when no second start ran (nothing happens otherwise)
  // A scene without normals has them derived from its rest shape, and the
  // optimizer keeps them while it designs the rest shape (docs/formats.md);
  // `rodmesh simulate` of the archived design derives them from the
  // archived rest shape. Where the equilibria under those normals lie
  // beyond the gap tolerance from the design's, the run goes on from its
  // design with the normals derived from its rest shape given (a fixed
  // point: the rest shape moves less each time, and so do the normals; each
  // such run is one joint phase), at most kNormalsRounds times; the last
  // run's model is the one the design is archived with, and the check
  // further below measures what is left.
  std::unique_ptr<Scene> normalsScene;
  std::unique_ptr<SceneModel> normalsModel;
  std::unique_ptr<DesignSpace> normalsSpace;
  const SceneModel* runModel = &model;
  const DesignSpace* runSpace = &space;
  for (int round = 0; round < kNormalsRounds; ++round) {
    if (!(scene.normals.empty() && model.network().normalSource() == "derived" && scene.design.restShape &&
          (r.outcome == Outcome::Converged || r.outcome == Outcome::Stalled) && r.usable &&
          r.design.restPositions != scene.vertices))
      break;
    double remaining = 0.0;  // --time-limit covers every run
    if (o.optimizer.timeLimit > 0 && !((remaining = o.optimizer.timeLimit - r.timeSeconds) > 1e-3)) break;
    const Scene at = sceneOfDesign(scene, r.design);
    const SceneModel atModel(at);
    if (atModel.network().vertexNormals() == runModel->network().vertexNormals() ||
        atModel.effects().planar != model.effects().planar || atModel.pose(0).numDofs() != model.pose(0).numDofs())
      break;
    // How far the design's equilibria move with the derived normals.
    if (o.optimizer.activity)
      o.optimizer.activity("re-solving the design from rest with the normals its rest shape derives");
    const int th = o.optimizer.threads;
    const SimulationResult withDerived = simulateAll(atModel, Design::fromScene(at), o.optimizer.newton, {}, false, th);
    const SimulationResult withUsed = simulateAll(*runModel, r.design, o.optimizer.newton, {}, false, th);
    if (!withDerived.allConverged || !withUsed.allConverged) break;
    const double gap = largestDistance(withDerived, withUsed);
    const PoseSystem& first = runModel->pose(0);
    if (!(gap > designedEquilibriumTolerance(r.rms, structureSize(first, r.design, first.restState(r.design)))))
      break;
    auto s2 = std::make_unique<Scene>(scene);
    s2->normals = atModel.network().vertexNormals();
    auto m2 = std::make_unique<SceneModel>(*s2);
    auto sp2 = std::make_unique<DesignSpace>(*s2, m2->effects());
    DesignOptimizerOptions again = o.optimizer;
    again.startControls = r.controls;
    again.startTargetPose = -1;
    // The design has been through the schedule once: one joint phase with
    // every control point continues it. The paper schedule would run its
    // radius levels and rest-shape rounds again and move the rest shape as
    // far as the first run did, and the normals with it, so that the gap
    // need not shrink from one run to the next.
    again.schedule = Schedule::Joint;
    if (again.timeLimit > 0) again.timeLimit = remaining;
    if (!quiet)
      std::fprintf(stderr,
                   "optimizer: %s (RMS %.4f mm): the scene gives no normals, and with those derived from the "
                   "design's rest shape its equilibria move by %.3g mm: once more from its design with those normals\n",
                   outcomeName(r.outcome), r.rms * 1e3, gap * 1e3);
    // Progress lines and the history go on from the run before.
    const int iterationBase = r.iterations;
    const double timeBase = r.timeSeconds;
    auto shifted = [&](const DesignIterate& it) {
      if (!progress) return;
      DesignIterate moved = it;
      moved.iteration += iterationBase;
      moved.elapsed += timeBase;
      progress(moved);
    };
    DesignOptimizerResult r3 = optimizeOn(*m2, *sp2, again, shifted);
    if (r3.start.empty() || !r3.usable || !(r3.outcome == Outcome::Converged || r3.outcome == Outcome::Stalled)) {
      addRunCost(r, r3);
      break;
    }
    // One run in the archive: the initial design (under the scene's own
    // derived normals) and the history are the first run's, continued.
    r3.initialPositions = std::move(r.initialPositions);
    r3.initialObjective = r.initialObjective;
    r3.initialRms = r.initialRms;
    std::vector<DesignIterate> history = std::move(r.history);
    for (std::size_t i = 1; i < r3.history.size(); ++i) {
      DesignIterate it = r3.history[i];
      it.iteration += iterationBase;
      it.elapsed += timeBase;
      history.push_back(std::move(it));
    }
    r3.history = std::move(history);
    char buf[240];
    std::snprintf(buf, sizeof buf,
                  "; the scene gives no normals: with those derived from the design's rest shape its equilibria "
                  "moved by %.3g mm, and the run went on from its design (RMS %.4f mm) with those normals given: ",
                  gap * 1e3, r.rms * 1e3);
    r3.message = r.message + buf + r3.message;
    r3.iterations += r.iterations;
    addRunCost(r3, r);
    r3.start = r.start;
    r = std::move(r3);
    normalsScene = std::move(s2);
    normalsModel = std::move(m2);
    normalsSpace = std::move(sp2);
    runModel = normalsModel.get();
    runSpace = normalsSpace.get();
  }
  // The process's peak so far: a second start or a normals run that is not
  // the one kept may have used more than the kept run had at its end.
  r.peakMemoryBytes = std::max(r.peakMemoryBytes, peakResidentMemory());
  if (!quiet) {
    std::cerr << "optimizer: " << outcomeName(r.outcome) << " (" << r.message << "), " << r.iterations
              << " iterations, " << r.evaluations << " evaluations, " << formatSeconds(r.timeSeconds) << "\n";
    std::fprintf(stderr, "time: %.2f s in model evaluations, %.2f s in the optimizer%s; peak memory %.1f MiB\n",
                 r.evaluationSeconds, r.solverSeconds, o.method == "sand" ? " (Ipopt, MUMPS)" : "",
                 static_cast<double>(r.peakMemoryBytes) / (1024.0 * 1024.0));
  }

  // Never report a design from the optimizer's own equilibria: re-solve
  // every pose from scratch (Newton from rest) under the final design or,
  // when a pose cannot be, under the best earlier design that can
  // (solver/design_fallback.hh).
  NewtonOptions resolve = o.optimizer.newton;
  resolve.cancel = nullptr;  // the archived design is re-solved whatever stopped the optimizer
  if (o.optimizer.activity) o.optimizer.activity("re-solving every pose of the final design from rest for the archive");
  ArchivedDesign chosen = chooseArchivedDesign(*runModel, *runSpace, r, resolve, o.optimizer.threads);
  // A scene inferred planar is optimized and re-solved in plane. When an
  // in-plane equilibrium of the archived design is unstable out of plane
  // (lateral buckling), `rodmesh simulate` solves the scene again in 3D with
  // twist (apps/run_simulate.cc); so does the archive, so that simulating
  // the archived design reproduces it.
  std::unique_ptr<Scene> spatialScene;
  std::unique_ptr<SceneModel> spatialModel;
  const SceneModel* archiveModel = runModel;
  std::string unstablePose;
  if (model.effects().planar && !scene.effects)
    for (const PoseResult& p : chosen.simulation.poses)
      if (p.outOfPlaneStable && !*p.outOfPlaneStable && unstablePose.empty()) unstablePose = p.name;
  if (!unstablePose.empty()) {
    spatialScene = std::make_unique<Scene>(cli::spatialScene(scene, model.effects()));
    spatialModel = std::make_unique<SceneModel>(*spatialScene);
    archiveModel = spatialModel.get();
    const double inPlaneRms = chosen.rms;
    chosen.simulation = simulateAll(*spatialModel, chosen.design, resolve, {}, false, o.optimizer.threads);
    chosen.allConverged = chosen.simulation.allConverged;
    chosen.rms = rmsError(chosen.simulation);
    chosen.outOfPlane = true;
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "the archived design's in-plane equilibrium of pose '%s' is unstable out of plane: every pose was "
                  "solved again in 3D with twist, as `rodmesh simulate` solves it (RMS %.4g mm in plane, %.4g mm in "
                  "3D); add \"effects\" to the scene to keep it in plane",
                  unstablePose.c_str(), inPlaneRms * 1e3, chosen.rms * 1e3);
    chosen.note += (chosen.note.empty() ? "" : "; ") + std::string(buf);
  }
  // A scene without normals has them derived from its rest shape (docs/
  // formats.md), and they are scene data: the optimizer keeps them while the
  // rest shape changes. `rodmesh simulate` of the archived design derives
  // them from the archived rest shape instead, so with a rest shape out of
  // its plane they differ, and so would its equilibria. Archive what simulate
  // solves, and say how far that is from the design under the scene's
  // normals; beyond the gap tolerance the archived equilibria are not the
  // designed ones (not converged).
  std::unique_ptr<Scene> renormalizedScene;
  std::unique_ptr<SceneModel> renormalizedModel;
  {
    const Scene& base = spatialScene ? *spatialScene : scene;
    // (The scene's own model says whether its normals are derived: the
    // normals round's model has them given.)
    const SceneModel& sourceModel = spatialModel ? *spatialModel : model;
    if (base.normals.empty() && sourceModel.network().normalSource() == "derived" &&
        chosen.design.restPositions != base.vertices) {
      auto resim = std::make_unique<Scene>(sceneOfDesign(base, chosen.design));
      auto resimModel = std::make_unique<SceneModel>(*resim);
      if (resimModel->network().vertexNormals() != archiveModel->network().vertexNormals() &&
          resimModel->effects().planar == archiveModel->effects().planar &&
          resimModel->pose(0).numDofs() == archiveModel->pose(0).numDofs()) {
        SimulationResult sim =
            simulateAll(*resimModel, Design::fromScene(*resim), resolve, {}, false, o.optimizer.threads);
        const double gap = largestDistance(sim, chosen.simulation);
        // Differences at the solver's own position tolerance (1e-9 of the
        // structure's size) are round-off of the derivation, not of the design.
        const PoseSystem& first = archiveModel->pose(0);
        if (gap > 1e-9 * structureSize(first, chosen.design, first.restState(chosen.design))) {
          const double before = chosen.rms;
          chosen.simulation = std::move(sim);
          chosen.allConverged = chosen.simulation.allConverged;
          chosen.rms = rmsError(chosen.simulation);
          chosen.renormalized = true;
          chosen.normalsGap = gap;
          const bool beyond = chosen.gapTolerance > 0 && gap > chosen.gapTolerance;
          if (beyond) chosen.offPath = true;
          char buf[600];
          std::snprintf(buf, sizeof buf,
                        "the scene gives no normals: they were derived from its rest shape and kept while the rest "
                        "shape was optimized, but `rodmesh simulate` derives them from the archived rest shape; "
                        "solved with those, as archived, the poses lie up to %.4g mm from the designed equilibria "
                        "(RMS %.4g mm, against %.4g mm)%s; give \"normals\" in the scene to keep them",
                        gap * 1e3, chosen.rms * 1e3, before * 1e3,
                        beyond ? ", beyond the gap tolerance: not the optimized equilibria" : "");
          chosen.note += (chosen.note.empty() ? "" : "; ") + std::string(buf);
          renormalizedScene = std::move(resim);
          renormalizedModel = std::move(resimModel);
          archiveModel = renormalizedModel.get();
        }
      }
    }
  }
  // A design whose pose sits at a critical point reaches its equilibrium
  // only as built and loaded exactly: say so (optimizers run to such
  // points when a target lies beyond the branch's end).
  addUnloadedStiffness(*archiveModel, chosen.design, chosen.simulation);
  // A design whose pose reaches its equilibrium only with the radii exactly
  // as designed (a bifurcation or limit point on its loading path within a
  // radius change of 0.1%): say so too. Two loading paths per pose.
  // The optimizer's own test of its final design (DesignOptimizerOptions::
  // imperfectionBackOff) is reused when that design is archived as solved.
  const SimulationResult& checked = r.imperfectionCheck;
  const bool reuse = !chosen.fallback && !chosen.outOfPlane && !chosen.renormalized &&
                     sameControls(chosen.controls, r.controls) &&
                     checked.poses.size() == chosen.simulation.poses.size();
  for (std::size_t p = 0; reuse && p < checked.poses.size(); ++p) {
    chosen.simulation.poses[p].imperfectionGap = checked.poses[p].imperfectionGap;
    chosen.simulation.poses[p].largestDisplacement = checked.poses[p].largestDisplacement;
  }
  // A run stopped by its time limit or by SIGINT/SIGTERM is archived without
  // the test (two loading paths per pose past the limit the user set).
  const bool cutShort = r.outcome == Outcome::TimeLimit || r.outcome == Outcome::Interrupted;
  if (!reuse && !cutShort)
    addImperfectionSensitivity(*archiveModel, chosen.design, resolve, chosen.simulation, o.optimizer.threads);
  for (const PoseResult& p : chosen.simulation.poses) {
    if (p.atCriticalPoint()) chosen.note += (chosen.note.empty() ? "" : "; ") + criticalPointNote(p);
    if (p.imperfectionSensitive()) chosen.note += (chosen.note.empty() ? "" : "; ") + imperfectionNote(p);
  }
  if (!chosen.note.empty()) std::cerr << "warning: " << chosen.note << "\n";
  r.peakMemoryBytes = std::max(r.peakMemoryBytes, peakResidentMemory());  // the re-solves included
  Archive a = optimizeArchive(scene, *archiveModel, *runSpace, r, chosen, o.method);
  a.version = versionString();
  if (o.method == "reduced")
    a.extraRootAttributes["design_derivatives"] = designDerivativesName(o.optimizer.designDerivatives);
  if (!quiet) {
    for (std::size_t p = 0; p < a.poses.size(); ++p) {
      const ArchivePose& ap = a.poses[p];
      std::fprintf(stderr, "pose %zu '%s': re-solved from rest under %s: %s, RMS %.4f mm", p, ap.name.c_str(),
                   chosen.label.c_str(), ap.status.c_str(), ap.rmsError.value_or(0.0) * 1e3);
      if (ap.initialPositions.rows() > 0 && ap.target.rows() == ap.initialPositions.rows())
        std::fprintf(stderr, " (initial design %.4f mm)",
                     std::sqrt((ap.initialPositions - ap.target).squaredNorm() / static_cast<double>(ap.target.rows())) *
                         1e3);
      if (ap.equilibriumGap) std::fprintf(stderr, ", gap to the optimizer's equilibrium %.3e m", *ap.equilibriumGap);
      std::cerr << "\n";
      const NewtonReport& rep = chosen.simulation.poses[p].report;
      if (!rep.converged()) std::cerr << "  reason: " << rep.message << "\n";
    }
  }
  std::optional<double> initialRms;
  if (!r.initialPositions.empty()) initialRms = r.initialRms;
  return {std::move(a), initialRms};
}

}  // namespace rodmesh::cli
