// The work of `rodmesh simulate` (apps/cmd_simulate.cc), shared with the
// Python module (python/): options, their checks, and the run that builds
// the archive.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>

#include "apps/cli_common.hh"
#include "apps/run.hh"
#include "solver/dynamics.hh"
#include "solver/equilibrium.hh"
#include "solver/mass.hh"
#include "solver/relaxation.hh"

namespace rodmesh::cli {

const char* versionString() { return "0.1.0"; }

namespace {

constexpr double kMaxFrames = 1e6;

// Ramp time of a dynamic run: --ramp if given; else, when a held vertex of the
// pose is prescribed away from its rest position (which it cannot jump to),
// a tenth of the duration; else 0 (loads at once, e.g. a sudden gravity).
double rampFor(const SimulateOptions& o, const Scene& scene, int pose) {
  if (o.ramp) return *o.ramp;
  for (const FixedVertex& f : scene.poses[pose].fixed)
    if (f.position && (*f.position - scene.vertices[f.vertex]).norm() > 0) return 0.1 * o.duration;
  return 0.0;
}

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

// Allowed ranges of the solver flags (usage errors name the flag, the value
// and the range). --tol: relative force residual; --max-iter: Newton
// iterations per load step (static), per time step (--dynamic), or force
// evaluations (relaxation).
constexpr double kMinTol = 1e-16, kMaxTol = 0.1;
constexpr int kMaxNewtonIter = 10000, kMaxStepNewtonIter = 1000, kMaxRelaxIter = 100000000;

void checkOptions(const SimulateOptions& o, const std::function<bool(const char*)>& given) {
  if (given("--tol") && !(o.newton.tolerance >= kMinTol && o.newton.tolerance <= kMaxTol))
    throw InputError("simulate: --tol " + number(o.newton.tolerance) + " is out of its allowed range [" +
                     number(kMinTol) + ", " + number(kMaxTol) + "] (force residual relative to the load scale)");
  if (given("--max-iter")) {
    const int hi = o.dynamic ? kMaxStepNewtonIter : o.staticSolver == "relaxation" ? kMaxRelaxIter : kMaxNewtonIter;
    if (o.newton.maxIterations < 1 || o.newton.maxIterations > hi)
      throw InputError("simulate: --max-iter " + std::to_string(o.newton.maxIterations) +
                       " is out of its allowed range [1, " + std::to_string(hi) + "]");
  }
  if (!o.dynamic) {
    for (const char* flag : {"--duration", "--fps", "--max-step", "--ramp"})
      if (given(flag)) throw InputError(std::string("simulate: ") + flag + " needs --dynamic");
  } else {
    if (!given("--duration")) throw InputError("simulate: --dynamic needs --duration SECONDS");
    if (given("--static-solver")) throw InputError("simulate: --static-solver does not apply to --dynamic");
    if (!(o.duration > 0) || !std::isfinite(o.duration))
      throw InputError("simulate: --duration must be a finite positive number of seconds, allowed range (0, inf), got " +
                       number(o.duration));
    if (!(o.fps > 0) || !std::isfinite(o.fps))
      throw InputError("simulate: --fps must be a finite positive number, allowed range (0, inf), got " + number(o.fps));
    if (o.duration * o.fps > kMaxFrames)
      throw InputError("simulate: --duration x --fps asks for " + number(o.duration * o.fps) +
                       " frames; allowed range: at most 1e6 frames (lower --fps or --duration)");
    // Every time step of a run counts against DynamicsOptions::maxSteps: a
    // largest step that cannot cover the duration within them is absurd.
    const double smallest = o.duration / static_cast<double>(o.dynamics.maxSteps);
    if (!(o.dynamics.maxStep >= smallest) || !std::isfinite(o.dynamics.maxStep))
      throw InputError("simulate: --max-step " + number(o.dynamics.maxStep) + " is out of its allowed range [" +
                       number(smallest) + ", inf) seconds for --duration " + number(o.duration) + " (at most " +
                       std::to_string(o.dynamics.maxSteps) + " time steps)");
    if (o.ramp && (!(*o.ramp >= 0) || !std::isfinite(*o.ramp)))
      throw InputError("simulate: --ramp must be a finite non-negative number of seconds, allowed range [0, inf), got " +
                       number(*o.ramp));
    if (std::string why = checkDynamicRun(o.dynamics, o.duration, o.fps, kMaxFrames); !why.empty())
      throw InputError("simulate: " + why);
  }
  if (std::string why = o.newton.isValid(); !why.empty()) throw InputError("simulate: " + why);
  if (o.staticSolver == "relaxation")
    if (std::string why = o.relaxation.isValid(); !why.empty()) throw InputError("simulate: " + why);
}

}  // namespace

void resolveSimulateOptions(SimulateOptions& o, const std::function<bool(const char*)>& given) {
  const bool maxIterGiven = given("--max-iter");
  const bool tolGiven = given("--tol");
  o.relaxation.tolerance = o.newton.tolerance;
  if (given("--time-limit")) {
    if (!(o.timeLimit > 0) || !std::isfinite(o.timeLimit))
      throw InputError("simulate: --time-limit must be a finite positive number of seconds, allowed range (0, inf), "
                       "got " + number(o.timeLimit));
    o.newton.timeLimit = o.relaxation.timeLimit = o.dynamics.timeLimit = o.timeLimit;
  }
  if (maxIterGiven) o.relaxation.maxIterations = o.newton.maxIterations;
  if (o.dynamic) {
    if (tolGiven) o.dynamics.tolerance = o.newton.tolerance;
    if (maxIterGiven) o.dynamics.maxNewtonIterations = o.newton.maxIterations;
    if (o.dynamics.maxStep > 0) {
      o.dynamics.initialStep = std::min(o.dynamics.initialStep, o.dynamics.maxStep);
      o.dynamics.minStep = std::min(o.dynamics.minStep, o.dynamics.maxStep);
    }
  }
  checkOptions(o, given);
}

Archive runSimulate(const Scene& scene, const SimulateOptions& o, bool quiet) {
  // Limits of the model that the scene may hit (e.g. a connection of more
  // than six rods) are input errors of this file.
  std::unique_ptr<SceneModel> modelPtr;
  try {
    modelPtr = std::make_unique<SceneModel>(scene);
  } catch (const std::invalid_argument& e) {
    throw InputError(scene.sourcePath + ": rods: " + e.what());
  }
  const SceneModel& model = *modelPtr;
  const Design design = Design::fromScene(scene);
  if (!quiet) printEffects(model.effects(), model.network(), model.pose(0).numDofs());

  Archive a;
  a.version = versionString();
  a.command = "simulate";
  a.sceneJson = scene.sourceText;
  describeModel(a, model.network(), model.effects(), model.numPoses() > 0 ? model.pose(0).numDofs() : 0);

  // Every pose goes through the archive builders shared with `optimize`
  // (apps/cli_common.hh); the progress line reads the archived values.
  bool twist = model.effects().has(Effect::Twist);
  // Why each pose that did not converge stopped (e.g. the load factor its
  // archived positions are in equilibrium at), for the root `message`.
  std::string reasons;
  auto addPose = [&](int p, const std::vector<Vec3>& positions, const Eigen::VectorXd& edgeTwist,
                     const PoseSolveSummary& solve, const std::string& details, const std::string& reason) {
    a.poses.push_back(makeArchivePose(scene.poses[p].name, positions, twist ? &edgeTwist : nullptr,
                                      scene.poses[p].target, solve));
    if (!reason.empty())
      reasons += (reasons.empty() ? "" : "; ") + ("pose '" + scene.poses[p].name + "': " + reason);
    if (quiet) return;
    const ArchivePose& r = a.poses.back();
    char line[512];
    std::snprintf(line, sizeof line, "pose %d '%s': %s, %s, residual %.3e N, %s", p, r.name.c_str(),
                  r.status == "converged" ? (o.dynamic ? "done" : "converged")
                                          : (r.status == "failed" ? "FAILED" : "NOT converged"),
                  details.c_str(), r.residualNorm, formatSeconds(r.timeSeconds).c_str());
    std::cerr << line;
    if (r.rmsError) std::fprintf(stderr, ", RMS error to target %.4f mm", *r.rmsError * 1e3);
    std::cerr << "\n";
    if (!reason.empty()) std::cerr << "  reason: " << reason << "\n";
  };
  // A pose solved by a solver that returns its unknowns and charts:
  // positions and material twists reported at the full load.
  auto addPoseFromDofs = [&](int p, const Eigen::VectorXd& u, const Charts& charts, const PoseSolveSummary& solve,
                             const std::string& details, const std::string& reason) {
    const PoseSystem& sys = model.pose(p);
    const PoseState state{u, charts, 1.0, {}};
    addPose(p, sys.positions(state, design), sys.materialTwists(state, design), solve, details, reason);
  };

  // The 3D scene and model of a planar scene that leaves its plane (below).
  std::unique_ptr<Scene> spatialScene;
  std::unique_ptr<SceneModel> spatialModel;
  if (o.dynamic) {
    a.extraRootAttributes["solver"] = "backward_euler";
    a.extraRootAttributes["duration_s"] = std::to_string(o.duration);
    a.extraRootAttributes["fps"] = std::to_string(o.fps);
    const std::vector<double> masses = lumpedVertexMasses(model.network(), design, scene.material.density);
    for (int p = 0; p < model.numPoses(); ++p) {
      const PoseSystem& sys = model.pose(p);
      const std::string& name = scene.poses[p].name;
      auto progress = [&](int frame, double t, const DynamicsReport& r) {
        if (quiet) return;
        std::fprintf(stderr, "pose %d '%s': frame %d, t = %.4f s, %d steps (%d rejected), %d Newton iterations\n", p,
                     name.c_str(), frame, t, r.steps, r.rejectedSteps, r.iterations);
      };
      DynamicsOptions dyn = o.dynamics;
      dyn.loadRampTime = rampFor(o, scene, p);
      if (!quiet && dyn.loadRampTime > 0)
        std::fprintf(stderr, "pose %d '%s': loads and held positions ramped in over %g s\n", p, name.c_str(),
                     dyn.loadRampTime);
      DynamicFrames frames;
      const DynamicsReport rep = simulateDynamics(sys, design, masses, dyn, o.duration, o.fps, frames, progress);
      PoseSolveSummary solve;
      // A step below its minimum fails; a step budget or time limit stops early.
      solve.solve = rep;
      char steps[96] = "";
      if (rep.steps > 0)
        std::snprintf(steps, sizeof steps, ", step %.3g to %.3g s", rep.minStepTaken, rep.maxStepTaken);
      char details[256];
      std::snprintf(details, sizeof details, "t = %.4f s in %d steps (%d rejected%s), %d Newton iterations", rep.time,
                    rep.steps, rep.rejectedSteps, steps, rep.iterations);
      addPoseFromDofs(p, frames.finalDofs, frames.finalState.charts, solve, details, rep.converged() ? "" : rep.message);
      ArchiveFrames af;
      af.name = name;
      af.time = Eigen::Map<const Eigen::VectorXd>(frames.time.data(), frames.time.size());
      for (const std::vector<Vec3>& x : frames.positions) af.positions.push_back(toRows(x));
      a.frames.push_back(std::move(af));
    }
  } else if (o.staticSolver == "relaxation") {
    a.extraRootAttributes["solver"] = "relaxation";
    for (int p = 0; p < model.numPoses(); ++p) {
      const PoseSystem& sys = model.pose(p);
      Eigen::VectorXd u = sys.restDofs(design);
      RelaxationOptions ro = o.relaxation;
      if (!quiet)
        ro.progress = [&](const RelaxationReport& r) {
          std::fprintf(stderr, "pose %d '%s': %d relaxation iterations, relative residual %.2e, step %.3g, %s\n", p,
                       scene.poses[p].name.c_str(), r.iterations, r.relativeResidual, r.finalStep,
                       formatSeconds(r.timeSeconds).c_str());
        };
      Charts charts;
      const RelaxationReport rep = relaxEquilibrium(sys, design, u, ro, &charts);
      PoseSolveSummary solve;
      solve.solve = rep;
      char details[256];
      std::snprintf(details, sizeof details,
                    "%d relaxation iterations, %d kinetic-energy peaks, relative residual %.1e", rep.iterations,
                    rep.restarts, rep.relativeResidual);
      addPoseFromDofs(p, u, charts, solve, details, rep.converged() ? "" : rep.message);
    }
  } else {
    a.extraRootAttributes["solver"] = "newton";
    // A scene inferred planar is solved in plane; when an in-plane
    // equilibrium turns out unstable against out-of-plane motion (lateral
    // buckling), the structure does not stay in its plane: every pose is
    // solved again in 3D with twist, and the archive is that model's.
    bool outOfPlaneUnstable = false;
    const bool mayLeavePlane = model.effects().planar && !scene.effects;
    auto progress = [&](int p, const PoseResult& pr) {
      if (mayLeavePlane && pr.outOfPlaneStable && !*pr.outOfPlaneStable) outOfPlaneUnstable = true;
      const PoseSolveSummary solve = newtonSolveSummary(pr);
      char details[256];
      std::snprintf(details, sizeof details, "%d Newton iterations, %d load steps, relative residual %.1e",
                    pr.report.iterations, pr.report.loadSteps, pr.report.relativeResidual);
      // Converged at the round-off floor (loads so small that the forces'
      // round-off is a large fraction of them): the relative residual above
      // the tolerance is that round-off, not an unfinished solve.
      if (pr.report.converged() && pr.report.roundoff)
        std::snprintf(details + std::strlen(details), sizeof details - std::strlen(details),
                      " (at the round-off floor of the forces, %.1e N)", pr.report.roundoffFloor);
      addPose(p, pr.positions, pr.twist, solve, details, pr.report.converged() ? "" : pr.report.message);
      if (!quiet)
        for (const CriticalPoint& cp : pr.report.criticalPoints)
          std::cerr << "  critical point at load factor " << cp.loadFactor << " (smallest stiffness eigenvalue "
                    << cp.smallestEigenvalue << " N/m): jumped " << cp.jump * 1e3 << " mm to the equilibrium beyond\n";
      if (!quiet && pr.atCriticalPoint())
        std::cerr << "  note: " << criticalPointNote(pr) << "\n";
      if (!quiet && pr.report.mechanismScale > 0)
        std::fprintf(stderr,
                     "  note: a mechanism (a mode without stiffness at rest) whose swing Newton completed with the "
                     "loads times %.0e, then brought back to the given loads\n",
                     pr.report.mechanismScale);
      if (!quiet && solve.outOfPlaneStable == 0)
        std::cerr << "  note: this in-plane equilibrium is unstable out of plane (a saddle of the 3D model)"
                  << (mayLeavePlane ? "; the scene is solved again in 3D\n"
                                    : "; the scene's \"effects\" keep it in plane (add \"twist\" to find the "
                                      "buckled state)\n");
    };
    simulateAll(model, design, o.newton, progress, /*unloadedStiffness=*/true, defaultOptimizeThreads());
    if (outOfPlaneUnstable) {
      spatialScene = std::make_unique<Scene>(cli::spatialScene(scene, model.effects()));
      spatialModel = std::make_unique<SceneModel>(*spatialScene);
      const SceneModel& model3d = *spatialModel;
      if (!quiet) {
        std::cerr << "an in-plane equilibrium is unstable out of plane: solving every pose in 3D with twist\n";
        printEffects(model3d.effects(), model3d.network(), model3d.pose(0).numDofs());
      }
      a.poses.clear();
      reasons.clear();
      describeModel(a, model3d.network(), model3d.effects(), model3d.numPoses() > 0 ? model3d.pose(0).numDofs() : 0);
      a.extraRootAttributes["effects_note"] =
          "the scene was inferred planar, but an in-plane equilibrium was unstable out of plane; solved in 3D "
          "with twist";
      twist = model3d.effects().has(Effect::Twist);
      simulateAll(model3d, design, o.newton, progress, /*unloadedStiffness=*/true,
                  defaultOptimizeThreads());
    }
  }

  bool allOk = true, anyFailed = false;
  for (const ArchivePose& r : a.poses) {
    allOk = allOk && r.status == "converged";
    anyFailed = anyFailed || r.status == "failed";
  }
  a.status = allOk ? "converged" : anyFailed ? "failed" : "not_converged";
  if (!reasons.empty()) a.extraRootAttributes["message"] = reasons;
  setRestAndRadii(a, design.restPositions, design.radii);
  return a;
}

}  // namespace rodmesh::cli
