// The one design driver of both optimizers (docs/optimization.md, "The design
// driver"). Everything a design run does besides moving the design within one
// phase is written here once:
//   - the initial design's equilibria and the run's history, progress lines
//     and timings;
//   - the schedule (designSchedule) and its rounds: which phase runs next,
//     the iteration and time limits, interrupts, the round-end test, targets
//     met to round-off;
//   - the phase ends: every candidate design a phase returns is polished by
//     Newton from the phase's own states and kept when its objective did not
//     rise; the kept design is re-solved along the loading path from rest and,
//     when that equilibrium is not the optimizer's, the run continues from the
//     loading-path state (issue of designs on the path, docs/optimization.md,
//     "Designs on the loading path");
//   - the retry of a diverged phase, the outcome-to-status mapping;
//   - best-design tracking: the monitor that confirms designs on a second
//     thread (solver/design_monitor.hh) and the fallback designs
//     (solver/design_fallback.hh).
// A phase solver moves the design within one phase: the reduced method's BFGS
// (solver/design_optimizer.cc) and SAND's Ipopt (nlp/sand_optimizer.cc).
#pragma once

#include "solver/design_optimizer.hh"

#include <memory>
#include <string>
#include <vector>

namespace rodmesh {

// One phase as the driver hands it to a phase solver.
struct PhaseTask {
  DesignStep step;
  int index = 0;               // position in the schedule (0 = first phase run)
  bool lastPhase = false;      // the schedule's last phase
  bool handsOver = false;      // a phase the schedule continues before any alternation (radius levels)
  int iterationBase = 0;       // run iterations before this phase
  int remainingIterations = 0; // of the run's --max-iter
  int attempt = 0;             // 0, or the how-many-th run of the same phase (a retry: diverged, ended off the
                               // loading path, or the last resort on the path)
  bool diverged = false;       // the retry of a phase whose iterates left equilibrium far behind, or that ended
                               // at an optimum no stable equilibrium realizes (DesignDriver::unreachedOptimum)
  bool onPath = false;         // the last phase run once more with every equilibrium solved from rest along the
                               // loading path, after it ended off the path twice (PhaseSolver::solvesOnPath)
  // The start: the best design so far, its equilibria (polished by Newton)
  // and objective.
  ControlValues controls;
  std::vector<PoseState> states;
  double objective = 0.0;
  std::string label;           // describeStep(step), for messages
};

// A design a phase proposes at its end, with the phase solver's own states
// under it (equilibria, or SAND's iterate: nearly equilibria).
struct PhaseCandidate {
  ControlValues controls;
  std::vector<PoseState> states;
};

// How a phase ended.
enum class PhaseEnd {
  Converged,       // the phase's own optimality test
  Stalled,         // the phase made no meaningful progress any more (the last phase: the run converged)
  PhaseCap,        // the phase's own iteration cap (the schedule goes on)
  IterationLimit,  // the run's --max-iter
  TimeLimit,       // --time-limit
  Interrupted,     // SIGINT, SIGTERM, a callback
  Diverged,        // the iterates left equilibrium far behind (or another divergence test, PhaseResult::message
                   // says which): the driver retries the phase once
  Failed,          // the phase solver failed (message says why)
  TargetsMet,      // every target met to round-off
};

struct PhaseResult {
  PhaseEnd end = PhaseEnd::Converged;
  std::string message;           // Failed, Stalled: why; Diverged: how, if not by leaving equilibrium; shown in the run's message
  Outcome failure = Outcome::NumericalFailure;  // Failed: Stalled (no further step possible) or NumericalFailure
  int iterations = 0, evaluations = 0, failedEvaluations = 0, equilibriumRestarts = 0;
  double evaluationSeconds = 0.0;
  // Best first: the driver polishes each, and keeps the first whose
  // objective did not rise and every later one that is lower still. A phase
  // solver whose iterates are not equilibria (SAND) puts its final point
  // first, when it has one, and the best nearly feasible iterate after it:
  // a later candidate kept then says the final point did worse
  // (DesignDriver::optimumWorseThanPassed).
  std::vector<PhaseCandidate> candidates;
};

class DesignDriver;

// What a phase solver may use while it runs: one call per optimizer
// iteration, the run's limits.
class PhaseContext {
 public:
  PhaseContext(DesignDriver& driver, const PhaseTask& task) : driver_(driver), task_(task) {}
  // Records an iteration: the history, the monitor (when `design` is given:
  // it is re-solved on the second thread), the fallbacks (when `equilibrium`:
  // `it` was evaluated at true equilibria of `design`), the progress callback.
  // Fills it.confirmedRms and it.confirmedIteration. Returns true when the
  // iterate meets every target to round-off (kTargetsMetRatio) and is
  // `settled` (an equilibrium, or within the solver's own settling tolerance).
  bool iterate(DesignIterate& it, const ControlValues* design, bool equilibrium, bool settled);
  // The run's limits: interrupted (SIGINT, callback) or past --time-limit.
  bool interrupted() const;
  bool timeUp() const;
  bool limitReached() const { return interrupted() || timeUp(); }
  double elapsed() const;             // s since the run's start
  double remainingTime() const;       // s left of --time-limit, +inf without one
  double initialObjective() const;
  const DesignOptimizerOptions& options() const;
  const PhaseTask& task() const { return task_; }

 private:
  DesignDriver& driver_;
  const PhaseTask& task_;
};

// A method that moves the design within one phase.
class PhaseSolver {
 public:
  virtual ~PhaseSolver() = default;
  // Once, after the initial design's equilibria (`states`, objective `f0`);
  // a non-empty return (bad options) ends the run as InvalidProblem.
  virtual std::string prepare(const std::vector<PoseState>& states, double f0) {
    (void)states;
    (void)f0;
    return "";
  }
  virtual PhaseResult solvePhase(const PhaseTask& task, PhaseContext& context) = 0;
  // After the driver's phase end: which of the phase's candidates is kept as
  // the best design (-1: none), for state the solver carries to the next
  // phase (SAND's multipliers).
  virtual void phaseEnded(int keptCandidate) { (void)keptCandidate; }
  // Whether the phase iterates are equilibria (the reduced method) or not
  // (SAND, whose equilibria come only with the phase end's polish); used in
  // messages.
  virtual bool iteratesAreEquilibria() const = 0;
  // How the solver runs the retry of a diverged phase (task.diverged), for
  // the run's message.
  virtual std::string divergedRetry() const { return "run again from the best design so far"; }
  // Whether the solver can run a phase with every equilibrium solved from
  // rest along the loading path (task.onPath): its designs are then on their
  // loading paths by construction, at the price of a loading path per pose
  // and evaluation.
  virtual bool solvesOnPath() const { return false; }
};

// The reduced method's phase solver (BFGS on the reduced objective,
// solver/design_optimizer.cc); `options` must outlive it. SAND also uses it
// to start its first phase (SandOptions::warmupIterations).
std::unique_ptr<PhaseSolver> makeReducedPhaseSolver(const SceneModel& model, const DesignSpace& space,
                                                    const DesignOptimizerOptions& options);

// The reduced method's Newton-CG phase solver (solver/design_optimizer.cc);
// `options` must outlive it. SAND also uses it for the retry of a phase whose
// Ipopt iterates diverged (SandOptions::newtonRetry).
std::unique_ptr<PhaseSolver> makeNewtonPhaseSolver(const SceneModel& model, const DesignSpace& space,
                                                   const DesignOptimizerOptions& options);

// Runs the schedule of `options` with `solver` and returns the run's result
// (solver/design_optimizer.hh).
DesignOptimizerResult runDesign(const SceneModel& model, const DesignSpace& space, const DesignOptimizerOptions& options,
                                PhaseSolver& solver, const DesignProgress& progress = {});

// Every pose solved by Newton from `states` under `d` (warm starts keep their
// charts; a failed warm start is restarted from rest along the loading
// path). False if a pose fails.
bool solvePosesFrom(const SceneModel& model, const Design& d, std::vector<PoseState>& states, const NewtonOptions& newton,
                    int threads);
// f (contract §4) of the states under `d`, and the summed squared distance
// to the targets (returned).
double objectiveOfStates(const SceneModel& model, const TargetObjective& objective, const Design& d,
                         const std::vector<PoseState>& states, double& f);

}  // namespace rodmesh
