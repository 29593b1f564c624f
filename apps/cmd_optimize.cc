// rodmesh optimize SCENE.json -o OUT.h5 [--method sand|reduced|newton] ...: design
// optimization (docs/formats.md §2 and §4). Finds the radii and rest
// shape (design.parameters) for which every pose's equilibrium reproduces its
// target, archives the design, its control points, the history, and every
// pose re-solved from scratch under the final design (or, when that fails,
// under the best earlier design that re-solves: solver/design_fallback.hh).
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "apps/cli_common.hh"
#include "apps/commands.hh"
#include "apps/flag_checks.hh"
#include "apps/run.hh"
#include "io/interrupt.hh"
#include "model/design_space.hh"
#include "solver/design_fallback.hh"
#include "solver/format.hh"
#include "solver/design_optimizer.hh"
#include "solver/equilibrium.hh"
#ifdef RODMESH_HAVE_NLP
#include "nlp/sand.hh"
#endif

namespace rodmesh::cli {

namespace {

// Keeps --time-limit, SIGINT and SIGTERM when the optimizer cannot answer
// them itself: it polls its limits between iterations, and one iteration can
// be a MUMPS factorization or a Newton solve that runs for minutes. When the
// run has not ended kGrace seconds after its time limit or after the first
// signal, the watchdog archives the best design confirmed so far (already
// re-solved from rest on the monitor's thread, solver/design_monitor.hh; the
// initial design before any other) and ends the process with exit 1; the
// archive's message says why. Unless quiet, it also says what the run is
// doing when no progress line came for --heartbeat seconds (a phase end's
// solves from rest, a long factorization), so a long silence is not taken
// for a hang.
class Watchdog {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr double kGrace = 3.0;  // s
  // After the time limit the optimizer still polishes its last designs
  // (short Newton solves from its own states); one that runs this much past
  // the limit is cancelled, before the watchdog's kGrace. A signal cancels
  // at once.
  static constexpr double kNewtonGrace = 1.0;  // s

  // `write(design, initial, history, message)` archives `design`.
  using Writer = std::function<void(const ConfirmedDesign& design, const ConfirmedDesign* initial,
                                    const std::vector<DesignIterate>& history, const std::string& message)>;

  // heartbeat: s without a progress line before it says what the run does (0: never).
  Watchdog(double timeLimit, double heartbeat, Writer write)
      : timeLimit_(timeLimit),
        heartbeat_(heartbeat),
        write_(std::move(write)),
        t0_(Clock::now()),
        lastProgress_(t0_),
        lastBeat_(t0_) {
    thread_ = std::thread([this] { run(); });
  }
  ~Watchdog() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;

  void confirmed(const ConfirmedDesign& d) {
    std::lock_guard<std::mutex> lock(mutex_);
    // The better one: with a second start (apps/run_optimize.cc) the second
    // run's monitor reports its own bests, which need not beat the first's.
    if (d.initial) initial_ = d;
    else if (!best_ || d.objective < best_->objective) best_ = d;
  }
  void iterate(const DesignIterate& it) {
    std::lock_guard<std::mutex> lock(mutex_);
    history_.push_back(it);
    lastProgress_ = Clock::now();
    activity_.clear();  // the next iteration, until the run says otherwise
  }
  // What the run does now (DesignOptimizerOptions::activity).
  void activity(const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex_);
    activity_ = what;
  }
  // The main thread's archive: true if it may write it; false when the
  // watchdog is writing its own (the process is about to end).
  // Set kNewtonGrace after the time limit, or once a signal arrived: the
  // optimizer's Newton solves stop on it (NewtonOptions::cancel).
  const std::atomic<bool>* limitFlag() const { return &limit_; }
  bool claimArchive() {
    int expected = 0;
    return state_.compare_exchange_strong(expected, 1);
  }

 private:
  void run() {
    std::optional<Clock::time_point> signalled;
    std::unique_lock<std::mutex> lock(mutex_);
    while (!done_) {
      wake_.wait_for(lock, std::chrono::milliseconds(100));
      if (done_) break;
      const auto now = Clock::now();
      if (!signalled && interruptRequested()) signalled = now;
      const double elapsed = std::chrono::duration<double>(now - t0_).count();
      if (heartbeat_ > 0 && !signalled && std::chrono::duration<double>(now - lastBeat_).count() >= heartbeat_ &&
          std::chrono::duration<double>(now - lastProgress_).count() >= heartbeat_) {
        const int next = history_.empty() ? 0 : history_.back().iteration + 1;
        const std::string what = !activity_.empty() ? activity_ : "iteration " + std::to_string(next);
        std::fprintf(stderr, "... %s: %s since the last progress line (%s into the run)\n", what.c_str(),
                     formatSeconds(std::chrono::duration<double>(now - lastProgress_).count()).c_str(),
                     formatSeconds(elapsed).c_str());
        lastBeat_ = now;
      }
      if (signalled || (timeLimit_ > 0 && elapsed > timeLimit_ + kNewtonGrace)) limit_ = true;
      const bool late = (timeLimit_ > 0 && elapsed > timeLimit_ + kGrace) ||
                        (signalled && std::chrono::duration<double>(now - *signalled).count() > kGrace);
      if (!late) continue;
      const ConfirmedDesign* design = best_ ? &*best_ : initial_ ? &*initial_ : nullptr;
      if (!design) continue;  // nothing re-solved from rest yet: the run answers as soon as it can
      int expected = 0;
      if (!state_.compare_exchange_strong(expected, 2)) return;  // the main thread is writing
      char why[256];
      if (signalled)
        std::snprintf(why, sizeof why, "interrupted (%s); the optimizer did not stop within %.0f s of the signal",
                      interruptSignal() == SIGTERM ? "SIGTERM" : "SIGINT", kGrace);
      else
        std::snprintf(why, sizeof why,
                      "time limit reached; the optimizer did not stop within %.0f s of the limit (stuck in one "
                      "computation)",
                      kGrace);
      const std::string message = std::string(why) + "; archived " + design->label +
                                  ", the best design confirmed from rest during the run";
      std::cerr << "warning: " << message << "\n";
      const std::vector<DesignIterate> history = history_;
      const ConfirmedDesign chosen = *design;
      const std::optional<ConfirmedDesign> initial = initial_;
      lock.unlock();
      int status = kExitNotConverged;
      try {
        write_(chosen, initial ? &*initial : nullptr, history, message);
      } catch (const std::exception& e) {
        std::cerr << "rodmesh: error: " << e.what() << "\n";
        status = kExitNotConverged;
      }
      std::fflush(nullptr);
      std::_Exit(status);
    }
  }

  double timeLimit_;
  double heartbeat_;
  Writer write_;
  Clock::time_point t0_;
  Clock::time_point lastProgress_, lastBeat_;  // the last progress line, the last line the watchdog wrote
  std::string activity_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool done_ = false;
  std::optional<ConfirmedDesign> best_, initial_;
  std::vector<DesignIterate> history_;
  std::atomic<int> state_{0};  // 0 running, 1 the main thread archives, 2 the watchdog archives
  std::atomic<bool> limit_{false};
  std::thread thread_;
};

}  // namespace

Command registerOptimize(CLI::App& root, const GlobalOptions& global) {
  auto opts = std::make_shared<OptimizeOptions>();
  CLI::App* app = root.add_subcommand("optimize", "design radii and rest shape so that every pose reaches its target");
  app->add_option("scene", opts->scene, "scene file with targets and a design block (rodmesh-scene/1 JSON)")
      ->required();
  app->add_option("-o,--output", opts->output, "result archive (HDF5)")->required();
  app->add_option("--method", opts->method,
                  "sand (simultaneous analysis and design, Ipopt; the default when built), reduced (the paper's "
                  "reduced-space BFGS) or newton (reduced-space trust-region Newton-CG with exact Hessian-vector "
                  "products)")
      ->check(CLI::IsMember({"sand", "reduced", "newton"}));
  app->add_option("--max-iter", opts->optimizer.maxIterations, "optimizer iterations over the whole schedule")
      ->check(wholeNumberIn(0, kMaxOptimizeIterations))
      ->capture_default_str();
  app->add_option("--time-limit", opts->optimizer.timeLimit, "wall-clock limit in seconds (0: none)")
      ->check(realNumberIn(kTimeLimitRange))
      ->capture_default_str();
  app->add_option("--tol", opts->optimizer.tolerance,
                  "relative tolerance; reduced, newton: projected gradient against its value at the start of a phase; sand: "
                  "Ipopt's tol and dual_inf_tol, the objective being scaled to 1 at the start of each phase")
      ->check(realNumberIn(kOptimizeTolRange))
      ->capture_default_str();
  app->add_option("--schedule", opts->schedule,
                  "paper (radii by levels, then rest shape and radii alternating; the default of --method reduced), "
                  "levels (radii by levels, then radii and rest shape together), "
                  "joint (everything at once; the default of --method sand and --method newton) or multilevel (everything together, "
                  "level by level)")
      ->check(CLI::IsMember({"paper", "joint", "levels", "multilevel"}));
  app->add_option("--threads", opts->optimizer.threads,
                  "poses solved in parallel (default: the machine's hardware threads; results do not depend on it)")
      ->check(wholeNumberIn(1, kMaxThreads))
      ->capture_default_str();
  app->add_option("--design-derivatives", opts->designDerivatives,
                  "--method reduced: exact (default: adjoint with exact dF/dp), fd (the paper's recipe: dF/dp by "
                  "central differences of the forces at the equilibrium) or fd-resolve (central differences of the "
                  "objective, every probe re-solving every pose)")
      ->check(CLI::IsMember({"exact", "fd", "fd-resolve"}));
  app->add_option("--ipopt", opts->ipopt, "KEY=VALUE option passed to Ipopt (--method sand; repeatable)");
  app->add_flag("--no-imperfection-back-off", opts->noImperfectionBackOff,
                "keep the final design even when a pose is imperfection-sensitive (its loading path reaches another "
                "equilibrium with the radii 0.1% off; by default the run backs off towards the initial design to "
                "the nearest design tested that is not)");
  app->add_option("--heartbeat", opts->heartbeat,
                  "seconds without a progress line after which a line says what the run is doing (a phase end's "
                  "solves from rest, a long factorization); 0: never")
      ->check(realNumberIn(kHeartbeatRange))
      ->capture_default_str();
  app->add_flag("--scene-start", opts->sceneStart,
                "start from the scene's rest shape even when the rest shape of a pose's target does better from rest "
                "(with rest_shape free, by default each such rest shape is solved from rest and the best start is "
                "used)");

  Command c;
  c.app = app;
  c.run = [opts, app, &global]() -> int {
    OptimizeOptions& o = *opts;
    checkOptimizeOptions(o);
    checkOutputPath(o.output, "-o", {o.scene});
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
    const SceneModel& model = *modelPtr;
    const DesignSpace& space = *spacePtr;
    checkOptimizeMemory(scene, space, o.method == "reduced");
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
    // The watchdog's archive: the confirmed design with its from-rest
    // positions, the history so far, status not_converged.
    auto watchdogWrite = [&](const ConfirmedDesign& d, const ConfirmedDesign* initial,
                             const std::vector<DesignIterate>& history, const std::string& message) {
      DesignOptimizerResult wr;
      wr.outcome = interruptRequested() ? Outcome::Interrupted : Outcome::TimeLimit;
      wr.message = message;
      wr.controls = d.controls;
      wr.design = d.design;
      wr.history = history;
      wr.iterations = history.empty() ? 0 : history.back().iteration;
      wr.timeSeconds = history.empty() ? 0.0 : history.back().elapsed;
      // Objective evaluations of the iterations so far: an iterate's count
      // runs within its phase, so a phase's total is its last iterate's.
      for (std::size_t i = 0; i < history.size(); ++i) {
        const DesignIterate& it = history[i];
        const bool phaseEnds = i + 1 == history.size() || history[i + 1].level != it.level ||
                               history[i + 1].phase != it.phase || history[i + 1].evaluations < it.evaluations;
        if (phaseEnds) wr.evaluations += it.evaluations;
      }
      wr.peakMemoryBytes = peakResidentMemory();
      if (initial) {
        wr.initialRms = initial->rms;
        wr.initialObjective = initial->objective;
        for (const PoseResult& p : initial->simulation.poses) wr.initialPositions.push_back(p.positions);
      }
      ArchivedDesign chosen;
      chosen.controls = d.controls;
      chosen.design = d.design;
      chosen.simulation = d.simulation;
      chosen.allConverged = true;
      chosen.fallback = true;  // not the optimizer's final design: no equilibrium gap
      chosen.label = d.label;
      chosen.rms = d.rms;
      Archive a = optimizeArchive(scene, model, space, wr, chosen, o.method);
      a.version = versionString();
      writeArchive(a, o.output);
      if (!quiet) std::cerr << "wrote " << o.output << " (" << a.status << ")\n";
    };
    Watchdog watchdog(o.optimizer.timeLimit, quiet ? 0.0 : o.heartbeat, watchdogWrite);
    o.optimizer.onConfirmed = [&watchdog](const ConfirmedDesign& d) { watchdog.confirmed(d); };
    o.optimizer.activity = [&watchdog](const std::string& what) { watchdog.activity(what); };
    o.optimizer.newton.cancel = watchdog.limitFlag();
    auto progress = [&](const DesignIterate& it) {
      watchdog.iterate(it);
      if (quiet) return;
      // The best design confirmed so far (re-solved from rest on the
      // monitor's thread) and the iteration that offered it.
      char best[64] = "";
      if (it.confirmedIteration >= 0)
        std::snprintf(best, sizeof best, "  best %.4f mm @%d", it.confirmedRms * 1e3, it.confirmedIteration);
      if (o.method == "sand")
        std::fprintf(stderr,
                     "iter %4d  level %d %-10s  f %.4e  RMS %.4f mm  viol %.2e N  dual inf %.2e  step %.2e  %s%s\n",
                     it.iteration, it.level, it.phase.c_str(), it.objective, it.rms * 1e3, it.constraintViolation,
                     it.dualInfeasibility, it.step, formatSeconds(it.elapsed).c_str(), best);
      else if (o.method == "newton")
        std::fprintf(stderr,
                     "iter %4d  level %d %-10s  f %.4e  RMS %.4f mm  |g| %.2e  step %.2e  cg %3d  radius %.2e  %s%s\n",
                     it.iteration, it.level, it.phase.c_str(), it.objective, it.rms * 1e3, it.gradientNorm, it.step,
                     it.cgIterations, it.trustRadius, formatSeconds(it.elapsed).c_str(), best);
      else
        std::fprintf(stderr, "iter %4d  level %d %-10s  f %.4e  RMS %.4f mm  |g| %.2e  step %.2e  viol 0 N  %s%s\n",
                     it.iteration, it.level, it.phase.c_str(), it.objective, it.rms * 1e3, it.gradientNorm, it.step,
                     formatSeconds(it.elapsed).c_str(), best);
    };
    OptimizeRun run = runOptimize(scene, model, space, o, progress, quiet);
    Archive& a = run.archive;
    const bool converged = a.status == "converged";
    const std::optional<double> rms = overallRmsError(a);
    if (!watchdog.claimArchive())
      for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));  // the watchdog writes and ends the process
    writeArchive(a, o.output);
    uninstallInterruptFlag();
    if (!quiet) {
      // The ratio only where both RMS errors are positive, and said the way
      // it went: a run can end worse than its initial design on the RMS
      // (the objective weighs poses by their weights); without the initial
      // design's equilibria (a run that could not solve them) there is
      // nothing to compare with.
      std::string change;
      if (rms && *rms > 0 && run.initialRms && *run.initialRms > 0 && std::isfinite(*run.initialRms)) {
        const double ratio = *run.initialRms / *rms, factor = ratio >= 1.0 ? ratio : 1.0 / ratio;
        change = formatNumber(factor < 100.0 ? ", %.2fx" : ", %.3gx", factor) + (ratio >= 1.0 ? " lower" : " higher");
      }
      if (run.initialRms)
        std::fprintf(stderr, "RMS error %.4f mm (initial design %.4f mm%s)\n", rms.value_or(0.0) * 1e3,
                     *run.initialRms * 1e3, change.c_str());
      else
        std::fprintf(stderr, "RMS error %.4f mm (not every pose of the initial design could be solved)\n",
                     rms.value_or(0.0) * 1e3);
      std::cerr << "wrote " << o.output << " (" << a.status << ")\n";
    }
    return converged ? kExitDone : kExitNotConverged;
  };
  return c;
}

}  // namespace rodmesh::cli
