// rodmesh optimize SCENE.json -o OUT.h5 [--method sand|reduced] ...: design
// optimization (../shared/contracts.md §2 and §4). Finds the radii and rest
// shape (design.parameters) for which every pose's equilibrium reproduces its
// target, archives the design, its control points, the history, and every
// pose re-solved from scratch under the final design (or, when that fails,
// under the best earlier design that re-solves: solver/design_fallback.hh).
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "apps/cli_common.hh"
#include "apps/commands.hh"
#include "io/interrupt.hh"
#include "model/design_space.hh"
#include "solver/design_fallback.hh"
#include "solver/design_optimizer.hh"
#include "solver/equilibrium.hh"
#ifdef RODMESH_HAVE_NLP
#include "nlp/sand.hh"
#endif

namespace rodmesh::cli {

namespace {

struct OptimizeOptions {
  std::string scene;
  std::string output;
  std::string method;  // sand (default when built) or reduced
  std::string schedule = "paper";
  std::string designDerivatives;  // exact (default), fd or fd-resolve; --method reduced only
  std::vector<std::string> ipopt;
  DesignOptimizerOptions optimizer;
};

bool sandAvailable() {
#ifdef RODMESH_HAVE_NLP
  return true;
#else
  return false;
#endif
}

void checkOptions(OptimizeOptions& o) {
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
  o.optimizer.schedule = o.schedule == "joint"    ? Schedule::Joint
                         : o.schedule == "levels" ? Schedule::Levels
                                                  : Schedule::Paper;
  if (std::string why = o.optimizer.isValid(); !why.empty()) throw InputError("optimize: " + why);
}

}  // namespace

Command registerOptimize(CLI::App& root, const GlobalOptions& global) {
  auto opts = std::make_shared<OptimizeOptions>();
  CLI::App* app = root.add_subcommand("optimize", "design radii and rest shape so that every pose reaches its target");
  app->add_option("scene", opts->scene, "scene file with targets and a design block (rodmesh-scene/1 JSON)")
      ->required();
  app->add_option("-o,--output", opts->output, "result archive (HDF5)")->required();
  app->add_option("--method", opts->method,
                  "sand (simultaneous analysis and design, Ipopt; the default when built) or reduced (the paper's "
                  "reduced-space BFGS)")
      ->check(CLI::IsMember({"sand", "reduced"}));
  app->add_option("--max-iter", opts->optimizer.maxIterations, "optimizer iterations over the whole schedule")
      ->capture_default_str();
  app->add_option("--time-limit", opts->optimizer.timeLimit, "wall-clock limit in seconds (0: none)")
      ->capture_default_str();
  app->add_option("--tol", opts->optimizer.tolerance,
                  "relative tolerance; reduced: projected gradient against its value at the start of a phase; sand: "
                  "Ipopt's tol and dual_inf_tol, the objective being scaled to 1 at the start of each phase")
      ->capture_default_str();
  app->add_option("--schedule", opts->schedule,
                  "paper (radii by levels, then rest shape and radii alternating), joint (everything at once) or "
                  "levels (radii by levels, then radii and rest shape together)")
      ->check(CLI::IsMember({"paper", "joint", "levels"}))
      ->capture_default_str();
  app->add_option("--threads", opts->optimizer.threads, "poses solved in parallel (results do not depend on it)")
      ->capture_default_str();
  app->add_option("--design-derivatives", opts->designDerivatives,
                  "--method reduced: exact (default: adjoint with exact dF/dp), fd (the paper's recipe: dF/dp by "
                  "central differences of the forces at the equilibrium) or fd-resolve (central differences of the "
                  "objective, every probe re-solving every pose)")
      ->check(CLI::IsMember({"exact", "fd", "fd-resolve"}));
  app->add_option("--ipopt", opts->ipopt, "KEY=VALUE option passed to Ipopt (--method sand; repeatable)");

  Command c;
  c.app = app;
  c.run = [opts, app, &global]() -> int {
    OptimizeOptions& o = *opts;
    checkOptions(o);
    checkOutputPath(o.output, "-o");
    const Scene scene = readSceneFile(o.scene);
    validateForOptimize(scene);
    const bool quiet = global.quiet;
    if (!quiet)
      for (const std::string& w : lastSceneWarnings()) std::cerr << "warning: " << w << "\n";
    std::unique_ptr<SceneModel> modelPtr;
    std::unique_ptr<DesignSpace> spacePtr;
    try {
      modelPtr = std::make_unique<SceneModel>(scene);
      spacePtr = std::make_unique<DesignSpace>(scene, modelPtr->effects());
    } catch (const std::invalid_argument& e) {
      throw InputError(scene.sourcePath + ": " + e.what());
    }
    SceneModel& model = *modelPtr;
    const DesignSpace& space = *spacePtr;
    if (!quiet) {
      printEffects(model.effects(), model.network(), model.numPoses() > 0 ? model.pose(0).numDofs() : 0);
      std::cerr << "design: " << (scene.design.radii ? "radii " : "") << (scene.design.restShape ? "rest_shape " : "")
                << "free; " << space.describe() << "; radius bounds [" << space.radiusLower() << ", "
                << space.radiusUpper() << "] m\n";
      std::cerr << "method: " << o.method
                << (o.method == "reduced" ? std::string(" (design derivatives ") +
                                                designDerivativesName(o.optimizer.designDerivatives) + ")"
                                          : std::string())
                << ", schedule " << o.schedule << ", " << o.optimizer.threads << " thread(s)\n";
#ifdef RODMESH_HAVE_NLP
      if (o.method == "sand" && ipoptOptionsFilePresent())
        std::cerr << "ipopt: reading options from ./ipopt.opt (they override rodmesh's defaults; --ipopt overrides "
                     "them)\n";
#endif
    }

    installInterruptFlag();
    o.optimizer.stopRequested = [] { return interruptRequested(); };
    auto progress = [&](const DesignIterate& it) {
      if (quiet) return;
      if (o.method == "sand")
        std::fprintf(stderr, "iter %4d  level %d %-10s  f %.4e  RMS %.4f mm  viol %.2e N  dual inf %.2e  step %.2e  %s\n",
                     it.iteration, it.level, it.phase.c_str(), it.objective, it.rms * 1e3, it.constraintViolation,
                     it.dualInfeasibility, it.step, formatSeconds(it.elapsed).c_str());
      else
        std::fprintf(stderr, "iter %4d  level %d %-10s  f %.4e  RMS %.4f mm  |g| %.2e  step %.2e  viol 0 N  %s\n",
                     it.iteration, it.level, it.phase.c_str(), it.objective, it.rms * 1e3, it.gradientNorm, it.step,
                     formatSeconds(it.elapsed).c_str());
    };
    DesignOptimizerResult r;
#ifdef RODMESH_HAVE_NLP
    if (o.method == "sand") {
      SandOptions so;
      so.optimizer = o.optimizer;
      for (const std::string& kv : o.ipopt) {
        const std::size_t eq = kv.find('=');
        so.ipopt.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
      }
      r = optimizeSand(model, space, so, progress);
    } else {
      r = optimizeReduced(model, space, o.optimizer, progress);
    }
#else
    r = optimizeReduced(model, space, o.optimizer, progress);
#endif
    if (!quiet) {
      std::cerr << "optimizer: " << outcomeName(r.status.outcome) << " (" << r.status.message << "), " << r.iterations
                << " iterations, " << r.evaluations << " evaluations, " << formatSeconds(r.timeSeconds) << "\n";
      std::fprintf(stderr, "time: %.2f s in model evaluations, %.2f s in the optimizer%s; peak memory %.1f MiB\n",
                   r.evaluationSeconds, r.solverSeconds, o.method == "sand" ? " (Ipopt, MUMPS)" : "",
                   static_cast<double>(r.peakMemoryBytes) / (1024.0 * 1024.0));
    }

    // Never report a design from the optimizer's own equilibria: re-solve
    // every pose from scratch (Newton from rest) under the final design or,
    // when a pose cannot be, under the best earlier design that can
    // (solver/design_fallback.hh).
    const ArchivedDesign chosen = chooseArchivedDesign(model, space, r, o.optimizer.newton);
    if (!chosen.note.empty()) std::cerr << "warning: " << chosen.note << "\n";
    Archive a = optimizeArchive(scene, model, space, r, chosen, o.method);
    a.version = versionString();
    if (o.method == "reduced")
      a.extraRootAttributes["design_derivatives"] = designDerivativesName(o.optimizer.designDerivatives);
    if (!quiet) {
      for (std::size_t p = 0; p < a.poses.size(); ++p) {
        const ArchivePose& ap = a.poses[p];
        const double initialRms =
            ap.initialPositions.rows() > 0 && ap.target.rows() == ap.initialPositions.rows()
                ? std::sqrt((ap.initialPositions - ap.target).squaredNorm() / static_cast<double>(ap.target.rows()))
                : 0.0;
        std::fprintf(stderr, "pose %zu '%s': re-solved from rest under %s: %s, RMS %.4f mm (initial design %.4f mm)", p,
                     ap.name.c_str(), chosen.label.c_str(), ap.status.c_str(), ap.rmsError.value_or(0.0) * 1e3,
                     initialRms * 1e3);
        if (ap.equilibriumGap) std::fprintf(stderr, ", gap to the optimizer's equilibrium %.3e m", *ap.equilibriumGap);
        std::cerr << "\n";
        const NewtonReport& rep = chosen.simulation.poses[p].report;
        if (!rep.converged) std::cerr << "  reason: " << rep.message << "\n";
      }
    }
    const bool converged = a.status == "converged";
    const std::optional<double> rms = overallRmsError(a);
    writeArchive(a, o.output);
    uninstallInterruptFlag();
    if (!quiet) {
      std::fprintf(stderr, "RMS error %.4f mm (initial design %.4f mm, %.1fx lower)\n", rms.value_or(0.0) * 1e3,
                   r.initialRms * 1e3, rms && *rms > 0 ? r.initialRms / *rms : 0.0);
      std::cerr << "wrote " << o.output << " (" << a.status << ")\n";
    }
    return converged ? kExitDone : kExitNotConverged;
  };
  return c;
}

}  // namespace rodmesh::cli
