// Design optimization shared by both optimizers, and the paper's reduced-space
// method (Pérez et al. 2015, §4.2-4.3; docs/formats.md §4).
//
// Problem: minimise f = 1/2 sum_k w_k sum_v |q_kv - target_kv|^2 over the
// design control values z (model/design_space.hh) subject to every pose's
// static equilibrium F_k(u_k, p(z)) = dE_k/du_k = 0 and the radius bounds.
// Positions q_kv are the pose's unknowns for free vertices and, for held
// vertices, their prescribed positions, which move with the rest shape.
//
// Reduced-space method: u_k(z) is solved by Newton at every evaluation
// (warm-started from the last accepted equilibrium with its charts, restarted
// from rest when that fails); the gradient is the adjoint one,
//   df/dz = J^T (df/dp - sum_k (dF_k/dp)^T lambda_k),  H_k lambda_k = df/du_k,
// with exact design derivatives (PoseSystem::designForceProduct) and one
// solve per pose with the equilibrium's Hessian. BFGS with a projected line
// search (solver/bfgs.hh) drives z through each phase of the schedule, which
// the design driver runs (solver/design_driver.hh): radii at levels
// 0, 1, 2, then rounds of rest shape and radii at the finest level
// (--schedule paper), or everything at once (--schedule joint). A phase ends
// on the projected-gradient test, on a relative decrease of the objective
// below phaseRelativeDecrease over phaseWindow iterations, or at its cap;
// the rounds end when one lowers the objective by less than
// roundRelativeDecrease (docs/optimization.md, "Schedule").
#pragma once

#include "model/design_space.hh"
#include "model/outcome.hh"
#include "solver/bfgs.hh"
#include "solver/bound_activity.hh"
#include "solver/design_fallback.hh"
#include "solver/design_monitor.hh"
#include "solver/equilibrium.hh"
#include "solver/newton.hh"
#include "solver/trust_region.hh"

#include <limits>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace rodmesh {

// The objective of contract §4 for one pose, and its derivatives.
class TargetObjective {
 public:
  TargetObjective(const Scene& scene, const EffectSet& effects);
  // f_k, with df/du (size of u) and df/dp (Design vector, direct dependence
  // through held vertices) added when asked.
  // sumSquared (optional) receives sum_v |q_v - target_v|^2.
  double pose(const PoseSystem& sys, const PoseState& state, const Design& d, Eigen::VectorXd* dfdu,
              Eigen::VectorXd* dfdp, double* sumSquared = nullptr) const;
  // Contract §3 RMS over all poses and vertices (m), from summed squared distances.
  double rms(double sumSquared) const;
  double weight(int pose) const { return weights_[pose]; }

 private:
  const Scene& scene_;
  const EffectSet& fx_;
  std::vector<double> weights_;
};

// Paper: radii level by level, then rest shape and radii alternating (the
// paper's §4.3, contract §4). Joint: every free parameter at the finest level
// from the start. Levels: radii level by level, then radii and rest shape
// together at the finest level (one phase instead of the alternation).
// Multilevel: every free parameter together, level by level (the paper's
// multiresolution without its alternation).
enum class Schedule { Paper, Joint, Levels, Multilevel };

// How the reduced method gets the design part of its gradient
// (docs/optimization.md, "Design derivatives").
//   Exact: (dF_k/dp)^T lambda_k by dual-number AD (the default).
//   FiniteDifference: the paper's recipe (§4.2: "we compute the force
//     Jacobian dF/dq analytically, but evaluate dF/dp using finite
//     differences"): every column dF_k/dz_i by central differences of the
//     force at the fixed equilibrium u_k, step fdForceStep x the variable's
//     scale; no equilibrium is re-solved.
//   FiniteDifferenceResolve: central differences of the reduced objective
//     f(u(z), z) itself, every probe re-solving every pose's equilibrium by
//     Newton warm-started from the equilibrium at z; step fdResolveStep x
//     the variable's scale.
enum class DesignDerivatives { Exact, FiniteDifference, FiniteDifferenceResolve };
const char* designDerivativesName(DesignDerivatives d);  // "exact", "fd", "fd-resolve"
// Relative steps (times designVariableScale) of the two finite-difference
// modes. Forces are evaluated to round-off, so the central-difference optimum
// eps^(1/3) applies; re-solved objectives carry the solver's stopping error
// too, so that mode takes a larger step (see docs/optimization.md).
constexpr double fdForceStep = 6e-6;
constexpr double fdResolveStep = 1e-4;

BfgsOptions reducedBfgsDefaults();
// The Newton method's trust region on the same scaled variables: radius 1 at
// a run's start (a step spanning one radius bound range or a tenth of the
// mean rod length in 2-norm), at most 100, Stalled below 1e-9; CG to a
// relative residual of 0.1 (tighter near the solution), at most 300 Hessian
// products per step; Steihaug's step to the radius on negative curvature
// (docs/optimization.md, "Newton-CG").
TrustRegionOptions newtonTrustRegionDefaults();

struct DesignOptimizerOptions {
  int maxIterations = 2000;    // optimizer iterations over the whole schedule (a limit, not the usual end:
                               // docs/optimization.md, "Stopping")
  double timeLimit = 0.0;      // s, 0 = none
  double tolerance = 1e-6;     // a phase converges when its projected gradient falls below this fraction of
                               // its value at the start of the phase
  Schedule schedule = Schedule::Paper;
  int threads = 1;             // poses solved in parallel; results do not depend on it
  DesignDerivatives designDerivatives = DesignDerivatives::Exact;  // reduced method only
  // When phases and the run stop (docs/optimization.md, "Schedule"):
  int maxLevelIterations = 40;          // BFGS iterations per radius level (paper schedule) ...
  int maxPhaseIterations = 100;         // ... and per rest-shape or radii phase of the alternation; the last
                                        // phase of a schedule without alternation has no cap of its own
  double phaseRelativeDecrease = 1e-3;  // a phase ends when the objective fell by less than this fraction ...
  int phaseWindow = 10;                 // ... over this many iterations
  double roundRelativeDecrease = 1e-2;  // the run ends when a rest-shape + radii round lowers the objective by
                                        // less than this fraction
  int maxAlternations = 20;             // rest-shape / radii rounds at most (paper schedule)
  // SAND: a phase also ends when its settled iterates lowered the objective
  // by less than stallRelativeDecrease over stallWindow iterations
  // (StallDetector).
  int stallWindow = 20;
  double stallRelativeDecrease = 1e-3;
  NewtonOptions newton;        // equilibrium solves
  // The reduced method's BFGS (solver/bfgs.hh) on the scaled variables
  // (designVariableScale: a step of 1 spans a radius bound range or a tenth
  // of the mean rod length): steps start at 0.1 and never exceed 10; a line
  // search gives up below 1e-9. Its iteration caps, time limit and stopping
  // tests are set per phase from the fields above.
  BfgsOptions bfgs = reducedBfgsDefaults();
  // The Newton method's trust-region Newton-CG (solver/trust_region.hh) on
  // the same scaled variables, with exact reduced Hessian products
  // (solver/reduced_hessian.hh); iteration caps, time limit and stopping
  // tests per phase as for BFGS. A phase that starts where the last phase
  // of the same kind (radii, rest shape, joint) ended starts with the radius
  // that phase ended with.
  TrustRegionOptions trustRegion = newtonTrustRegionDefaults();
  std::function<bool()> stopRequested;  // SIGINT
  // What the run does between iterations, when that is more than the next
  // iteration (a phase end's solves from rest, the choice of a retry's start,
  // the imperfection back-off): called with a short description as each such
  // step begins, so that a front end can say what a long silence is.
  std::function<void(const std::string&)> activity;
  // Re-solve the optimizer's designs on a second thread while it runs
  // (solver/design_monitor.hh): the run holds a design that re-solves from
  // rest at every moment, and ends with the better of it and its own.
  bool confirmDesigns = true;
  // When the run's final design is imperfection-sensitive
  // (solver/equilibrium.hh, addImperfectionSensitivity: a pose's loading
  // path reaches another equilibrium with its radii 0.1% off), back off
  // towards the initial design to the nearest design tested that is not and
  // does better than the initial one (docs/optimization.md, "Imperfection
  // back-off").
  bool imperfectionBackOff = true;
  // Leave that back-off to the caller (completeImperfectionBackOff): a front
  // end that runs the schedule more than once (a second start) and keeps
  // one result backs off only the one it keeps.
  bool deferImperfectionBackOff = false;
  // With the rest shape free, also try as the start the rest shapes in which
  // one pose's target is the unloaded shape, each solved from rest; the
  // best of them and the initial design is where the schedule starts
  // (docs/optimization.md, "The start").
  bool startFromTargets = true;
  // The second start of a run whose targets were not met from the scene's
  // rest shape (apps/run_optimize.cc, docs/optimization.md "A second
  // start"): the pose (index) whose target's rest shape is the start
  // however little it gains on the initial design (the first run's
  // startCandidatePose); only that rest shape is solved, and the run ends at
  // once (InvalidProblem) when it cannot be solved from rest or does no
  // better than the initial design. -1: the rule of startFromTargets.
  int startTargetPose = -1;
  // A run that goes on from a design found before (apps/run_optimize.cc:
  // a scene without normals run again with the normals derived from its
  // optimized rest shape): the schedule starts from these control values,
  // solved from rest, instead of the initial design and the targets' rest
  // shapes; the run ends at once (InvalidProblem) when they cannot be solved
  // from rest. Unset: the rules above.
  std::optional<ControlValues> startControls;
  // Called on the monitor's thread with every newly confirmed best design.
  std::function<void(const ConfirmedDesign&)> onConfirmed;
  std::string isValid() const;
};

// One optimizer iteration, for progress lines and the archive history.
struct DesignIterate {
  int iteration = 0;
  int level = 0;
  std::string phase;  // "radii", "rest_shape" or "joint"
  double objective = 0.0, rms = 0.0, gradientNorm = 0.0, step = 0.0, elapsed = 0.0;
  int evaluations = 0;
  // SAND: the largest equilibrium residual at the iterate (N) and Ipopt's
  // dual infeasibility; 0 for the reduced method (its iterates are equilibria).
  double constraintViolation = 0.0, dualInfeasibility = 0.0;
  // Newton: Hessian-vector products (CG iterations) of the accepted step and
  // the trust radius after it; -1 and NaN for the other methods.
  int cgIterations = -1;
  double trustRadius = std::numeric_limits<double>::quiet_NaN();
  // The best design confirmed so far (re-solved from rest on the monitor's
  // thread, solver/design_monitor.hh): its RMS (m) and the iteration that
  // offered it; NaN and -1 before the first.
  double confirmedRms = std::numeric_limits<double>::quiet_NaN();
  int confirmedIteration = -1;
};

// What an optimizer run reports: the summary every solve reports
// (model/outcome.hh: outcome, whether the design is usable, iterations,
// residualNorm = the largest force residual of the result's equilibria (N),
// wall time, message) and the design, its equilibria and the run's history.
struct DesignOptimizerResult : SolveSummary {
  ControlValues controls;                // final (best) design
  Design design;
  std::vector<PoseState> states;         // the optimizer's own equilibria under `design`
  std::vector<std::vector<Vec3>> initialPositions;  // equilibria under the initial design
  double initialObjective = 0.0, initialRms = 0.0;
  double objective = 0.0, rms = 0.0;
  int evaluations = 0, failedEvaluations = 0, equilibriumRestarts = 0;
  double evaluationSeconds = 0.0;       // in model evaluations (objective, equilibria, derivatives)
  double solverSeconds = 0.0;           // in the optimizer itself (SAND: Ipopt and MUMPS)
  long peakMemoryBytes = 0;             // peak resident memory of the process at the end
  std::vector<DesignIterate> history;   // starts with iteration 0 (initial design)
  // Earlier accepted designs, best objective first, the initial one not
  // included (solver/design_fallback.hh): the reduced method's accepted
  // iterates and phase ends, SAND's kept phase designs.
  std::vector<FallbackDesign> fallbacks;
  // The final design's imperfection test (imperfectionBackOff): its poses
  // solved from rest with imperfectionGap and largestDisplacement set, for
  // the archive to reuse when it archives that design; empty when not run.
  SimulationResult imperfectionCheck;
  // How much the radius bounds hold the final design back
  // (solver/bound_activity.hh); not computed when radii are not free or the
  // run has no usable equilibria.
  RadiusBoundActivity boundActivity;
  // Where the schedule started: empty for the scene's rest shape, otherwise
  // the rest shape of a target ("the rest shape of pose 'NAME''s target").
  std::string start;
  // The best target's rest shape that did better from rest than the initial
  // design, whether or not the run started there (empty: none did, or none
  // was tried): what a second start would start from.
  std::string startCandidate;
  int startCandidatePose = -1;  // its pose index
  ControlValues startControls;  // the design the schedule started from
  // The imperfection back-off was deferred (deferImperfectionBackOff) and
  // has not run yet; boundActivity is then not computed either.
  bool imperfectionBackOffPending = false;
};

// The back-off a run deferred (DesignOptimizerOptions::
// deferImperfectionBackOff), on its result: the design may change, the
// message says so, imperfectionCheck, the equilibria's summary and the bound
// activity are set as the run would have set them, and the time is added.
// `options` are the run's, with timeLimit the time left for this (0: none).
// Nothing happens when no back-off is pending.
void completeImperfectionBackOff(const SceneModel& model, const DesignSpace& space,
                                 const DesignOptimizerOptions& options, DesignOptimizerResult& result);

// The phases of a schedule (paper: radii level by level, then rounds of rest
// shape and radii at the finest level; joint: everything at the finest).
// `round` numbers the rounds of the alternation (1, 2, ...; 0 outside it).
struct DesignStep {
  DesignPhase phase;
  int round = 0;
};
std::vector<DesignStep> designSchedule(const Scene& scene, const DesignSpace& space,
                                       const DesignOptimizerOptions& options);
const char* phaseName(const DesignPhase& phase);
// "radii level 1", "rest_shape round 2" or "joint level 2", for messages.
std::string describeStep(const DesignStep& step);
// Scale of each free variable of a phase (radii: the bound range;
// displacements: a tenth of the mean rod length), so that optimizer steps
// are comparable across kinds.
Eigen::VectorXd designVariableScale(const DesignSpace& space, const DesignPhase& phase, const Scene& scene);
// Peak resident memory of this process (bytes).
long peakResidentMemory();

using DesignProgress = std::function<void(const DesignIterate&)>;

// When further iterations cannot lower the objective meaningfully
// (docs/optimization.md, "Stopping"): over the last `window` iterations the
// best objective among settled iterates (equilibria, or SAND iterates within
// a small fraction of the load of equilibrium) fell by less than
// `relativeDecrease` of its value, and every iterate of the window was near
// equilibrium (an optimizer on an excursion away from the constraints, to
// come back lower, is not stalled).
//
// Also stalled when the window lowered the RMS by less than
// kMeaningfulRmsPerIteration x window of the initial design's RMS
// (`initialObjective` > 0; RMS ~ sqrt(f)).
class StallDetector {
 public:
  StallDetector(int window, double relativeDecrease, double initialObjective = 0.0)
      : window_(window), relative_(relativeDecrease), initial_(initialObjective) {}
  // One iterate: its objective if it is settled (+inf otherwise), and
  // whether it is near equilibrium.
  void add(double settledObjective, bool nearEquilibrium);
  bool stalled() const;
  double best() const;  // the lowest settled objective so far (+inf if none)

 private:
  int window_;
  double relative_, initial_;
  std::vector<double> best_;        // running minimum of the settled objective, per iterate
  std::vector<char> near_;          // near equilibrium, per iterate
};

// Targets met to round-off: the objective at most this fraction of the
// initial design's (RMS at most 1e-6 of the initial RMS), at an equilibrium.
constexpr double kTargetsMetRatio = 1e-12;
// An initial design whose RMS error is below this fraction of the
// structure's size (the largest coordinate range of its vertices, the
// driver's structureSize) already meets every
// target: what is left is the round-off of its equilibrium solves, and an
// optimizer started there faces a degenerate problem (zero objective,
// multipliers undetermined) with nothing to gain.
constexpr double kTargetsMetExtent = 1e-10;
// Progress in RMS slower than this fraction of the initial design's RMS per
// iteration is not meaningful to a designer: 1e-4 of it over 20 iterations
// (2 micrometres on a 20 mm initial error), 1e-3 over a 200-iteration round.
constexpr double kMeaningfulRmsPerIteration = 5e-6;
// Whether going from objective `before` to `after` in `iterations`
// iterations lowered the RMS by at least kMeaningfulRmsPerIteration x
// iterations of the initial design's RMS (objective `initial`).
bool meaningfulGain(double before, double after, double initial, int iterations);

// At the end of a run (the monitor stopped): the monitor's best design joins
// the fallbacks and, when `outcome` is not Converged and its objective from
// rest is lower than the run's own result, becomes the result (`states`: its
// warm-started equilibria). True if it did. A run that ends by its own tests
// keeps its own final design, so that its result does not depend on how far
// the monitor's thread got; a run cut short (limit, signal, failure) is
// timing-dependent anyway and keeps the better design.
bool adoptConfirmed(const DesignMonitor& monitor, Outcome outcome, DesignOptimizerResult& res,
                    std::vector<PoseState>& states, DesignFallbacks& fallbacks);

DesignOptimizerResult optimizeReduced(const SceneModel& model, const DesignSpace& space,
                                      const DesignOptimizerOptions& options, const DesignProgress& progress = {});
// The reduced-space Newton method: the same objective, schedule and driver,
// each phase by trust-region Newton-CG with exact Hessian-vector products
// (docs/optimization.md, "Newton-CG"). Exact design derivatives only.
DesignOptimizerResult optimizeNewton(const SceneModel& model, const DesignSpace& space,
                                     const DesignOptimizerOptions& options, const DesignProgress& progress = {});

// The reduced objective of one phase as a function of its free variables z:
// value and adjoint gradient (exposed for tests).
class ReducedObjective {
 public:
  ReducedObjective(const SceneModel& model, const DesignSpace& space, const TargetObjective& objective,
                   const DesignPhase& phase, const ControlValues& base, const NewtonOptions& newton, int threads,
                   std::vector<PoseState> warm);
  // Gradients by finite differences instead of the exact design derivatives
  // (DesignDerivatives); `scale` (size of z) is each variable's scale, the
  // step being the mode's relative step times it.
  void setDesignDerivatives(DesignDerivatives mode, const Eigen::VectorXd& scale);
  // The run's limits (interrupt, time limit): once `stop` returns true, an
  // evaluation that would solve fails at once, and fd-resolve checks it
  // between its re-solves (each probe re-solves every pose).
  void setStop(std::function<bool()> stop) { stop_ = std::move(stop); }
  // f(z), and its gradient when g != nullptr. False when an equilibrium
  // cannot be found under this design.
  bool evaluate(const Eigen::VectorXd& z, double& f, Eigen::VectorXd* g);
  // Makes the equilibria of the last successful evaluation at z the warm start.
  void accept(const Eigen::VectorXd& z);
  // For the next solve only: predicted changes of every pose's unknowns from
  // the warm start (the Newton method's first-order prediction
  // du = -H^-1 dF/dp dp); a pose starts from the warm start plus its change
  // when the force residual there is smaller than at the warm start itself.
  void predict(std::vector<Eigen::VectorXd> du) { prediction_ = std::move(du); }
  // Every equilibrium solved from the rest state along the loading path, as
  // `rodmesh simulate` solves it, instead of warm-started (no prediction):
  // the objective is then that of the loaded object, and every design the
  // optimizer accepts is on its loading path by construction (the driver's
  // last resort, PhaseTask::onPath).
  void setFromRest(bool fromRest) {
    fromRest_ = fromRest;
    lastZ_.resize(0);  // the cached equilibria may be another branch's
  }
  const std::vector<PoseState>& warmStates() const { return warm_; }
  // The equilibria of the last successful evaluation if it was at z, else null.
  const std::vector<PoseState>* statesAt(const Eigen::VectorXd& z) const {
    return lastZ_.size() == z.size() && lastZ_ == z ? &lastStates_ : nullptr;
  }
  double lastSumSquared() const { return lastSumSq_; }
  int failedSolves() const { return failedSolves_; }
  int restarts() const { return restarts_; }
  double evaluationSeconds() const { return seconds_; }  // spent in evaluate()

 private:
  bool evaluateImpl(const Eigen::VectorXd& z, double& f, Eigen::VectorXd* g);
  bool solvePoses(const Design& d, std::vector<PoseState>& states);
  // f at z solved from `start` (fd-resolve probes); false when a solve fails.
  bool probeObjective(const Eigen::VectorXd& z, const std::vector<PoseState>& start, double& f);
  const SceneModel& model_;
  const DesignSpace& space_;
  const TargetObjective& objective_;
  DesignPhase phase_;
  ControlValues base_;
  NewtonOptions newton_;
  int threads_;
  Eigen::SparseMatrix<double> J_;
  std::vector<PoseState> warm_;
  DesignDerivatives derivatives_ = DesignDerivatives::Exact;
  Eigen::VectorXd fdScale_;
  std::function<bool()> stop_;
  std::vector<Eigen::VectorXd> prediction_;
  bool fromRest_ = false;
  // Cache of the last successful evaluation.
  Eigen::VectorXd lastZ_;
  std::vector<PoseState> lastStates_;
  double lastF_ = 0.0, lastSumSq_ = 0.0, seconds_ = 0.0;
  int failedSolves_ = 0, restarts_ = 0;
};

}  // namespace rodmesh
