// Bound-constrained quasi-Newton minimisation for the reduced-space design
// optimizer (Pérez et al. 2015, §4.2: "a quasi-newton method with constraint
// projection ... BFGS with line-search. When the new search direction fails to
// reduce the objective function, we switch to steepest descent ... a maximum
// step-length which is adaptively refined depending on success").
//
// Written for objectives that are expensive and may fail: one evaluation solves
// the static equilibria of several poses, and an equilibrium may not be found.
// A failed evaluation (the objective returns false, or a non-finite value or
// gradient) is never accepted; inside a line search it shortens the step.
// Cost: an iteration is one or more value-only probes plus one gradient call at
// the accepted point, which repeats the last probe's x; an objective that keeps
// the equilibria of its last call can make that second call cheap.
//
// Algorithm (one iteration):
//  - Active set: a variable at a bound whose gradient points outward (descent
//    would leave the box) is held; its projected-gradient component is zero.
//  - Direction: d = -H Pg on the free variables, H the dense BFGS approximation
//    of the inverse Hessian. Components that would push a variable already at a
//    bound further out are dropped. Until curvature is known (first iteration,
//    after a reset, or while every pair had y's <= 0) the direction is steepest
//    descent, -Pg. Either is scaled so that |step|_inf <= the current maximum step.
//  - Line search along the projected path x(a) = P(x + a d), P the projection
//    onto the box, with the Armijo test f(x(a)) <= f + armijo * g'(x(a) - x).
//    Probes request the value only; the gradient is requested once, at the
//    point about to be accepted. A rejected probe shrinks a by safeguarded
//    quadratic interpolation (factor in [0.1, 0.5]); a failed evaluation shrinks
//    it by stepShrink. The search fails after maxBacktracks reductions or when
//    |step|_inf falls below minStep.
//  - Fallback: if the BFGS direction is not a descent direction or its line
//    search fails, H is reset and the iteration retries along steepest descent
//    with a shrunk maximum step. If steepest descent fails too (down to its
//    smallest trial step), the run ends with Outcome::Stalled.
//  - Update: H is updated with s = x+ - x, y = g+ - g when y's > 1e-10 |s||y|
//    (otherwise the pair is skipped); the first pair after a reset scales the
//    identity by y's / y'y before updating.
//  - Maximum step: grows by stepGrowth after a full step that the cap limited;
//    after a step that needed backtracking (or met failed evaluations) it
//    becomes the length of the accepted step; after a failed line search it
//    shrinks by stepShrink. It stays within [minStep, maxStepLimit].
//
// Stopping tests, checked at every accepted point:
//  - Converged, "projected gradient below tolerance": |Pg|_inf <= gradientTolerance * scale,
//    scale = gradientScale if set, else |Pg(x0)|_inf. Relative to the initial
//    projected gradient, the test is unchanged when f is multiplied by a constant
//    or the variables by a common factor (radii in metres or millimetres);
//    pass gradientScale when restarting from a point that is nearly optimal.
//  - Converged, "relative decrease below ...": f(k - stallWindow) - f(k) <=
//    relativeDecrease * |f(k - stallWindow)|, after at least stallWindow
//    iterations. This test also ends a run that creeps up to a region where
//    evaluations fail (a wall it cannot cross); relativeDecrease = 0 turns it
//    off, and such a run then ends as Stalled.
//  - MaxIterations, TimeLimit (checked before every evaluation), Interrupted
//    (stopRequested, polled before every evaluation), Stalled (see above),
//    NumericalFailure (x0 cannot be evaluated), InvalidProblem (bad options,
//    bounds or sizes).
//
// The result is always the best point evaluated successfully (value probes
// included), with its value; x and f are finite. If no point was evaluated,
// x is the projected x0 and f is +infinity. The run is deterministic for a
// deterministic objective. Exceptions thrown by the objective propagate.
#pragma once

#include "model/outcome.hh"

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace rodmesh {

struct BfgsOptions {
  int maxIterations = 200;          // accepted steps
  double timeLimit = 0;             // s of wall-clock time, 0 = none
  double gradientTolerance = 1e-6;  // converged when |Pg|_inf <= gradientTolerance * gradient scale
  double gradientScale = 0;         // scale of the gradient test; 0 = |Pg(x0)|_inf
  double relativeDecrease = 1e-9;   // converged when f fell by <= relativeDecrease * |f| ...
  int stallWindow = 5;              // ... over this many iterations
  double initialMaxStep = 1;        // cap on |step|_inf at the start, in variable units
  double minStep = 1e-12;           // floor of the cap; a line search gives up below it. Set it to the
                                    // smallest change that matters: failed searches then cost fewer calls
  double stepGrowth = 2;            // cap *= stepGrowth after a full step limited by the cap
  double stepShrink = 0.25;         // cap *= stepShrink after a failed line search;
                                    // trial step *= stepShrink after a failed evaluation
  double armijo = 1e-4;             // sufficient-decrease constant
  int maxBacktracks = 20;           // step reductions per line search
  // Ceiling of the cap on |step|_inf.
  double maxStepLimit = std::numeric_limits<double>::infinity();
  // Up to denseLimit variables the inverse-Hessian approximation is a dense
  // matrix (full BFGS, 8 n^2 bytes: 3.2 GB at the limit); above it, limited
  // memory: the last `memory` curvature pairs, applied by the two-loop
  // recursion (16 n memory bytes).
  int denseLimit = 20000;
  int memory = 20;

  std::string isValid() const;  // empty if valid, else what is wrong
};

// One line of the iteration history. Iteration 0 is the initial point.
struct BfgsIterate {
  int iteration = 0;
  double f = 0;                      // objective at the accepted point
  double projectedGradientNorm = 0;  // |Pg|_inf at the accepted point
  double step = 0;                   // |x_k - x_{k-1}|_inf, 0 for iteration 0
  double maxStep = 0;                // cap on |step|_inf after this iteration
  bool steepest = false;             // the accepted step followed steepest descent
  double elapsed = 0;                // s since the start
  int evaluations = 0;               // objective calls so far (value and gradient)
};

struct BfgsResult {
  Status status;
  Eigen::VectorXd x;                                   // best point evaluated successfully
  double f = std::numeric_limits<double>::infinity();  // objective at x
  double projectedGradientNorm = 0;                    // |Pg|_inf at the last accepted point
  int iterations = 0;                                  // accepted steps
  int evaluations = 0;                                 // objective calls, value and gradient
  int gradientEvaluations = 0;                         // calls that asked for the gradient (one per accepted point)
  int failedEvaluations = 0;                           // calls that returned false or non-finite values
  int steepestSteps = 0;   // accepted steps along steepest descent (including those before curvature is known)
  int fallbacks = 0;       // BFGS directions abandoned for steepest descent
  int skippedUpdates = 0;  // BFGS updates skipped because y's was not positive enough
  double maxStep = 0;      // final cap on |step|_inf
  double timeSeconds = 0;
  std::vector<BfgsIterate> history;  // one entry per iteration, starting with iteration 0
};

// Evaluates the objective at x: the value into f and, when g is not null, the
// gradient into *g (resized by the callee if needed). Returns false when the
// point cannot be evaluated (e.g. no static equilibrium was found).
using BfgsObjective = std::function<bool(const Eigen::VectorXd& x, double& f, Eigen::VectorXd* g)>;

struct BfgsCallbacks {
  std::function<void(const Eigen::VectorXd& x)> accepted;  // after each accepted step (warm starts)
  std::function<void(const BfgsIterate&)> progress;        // once per iteration, including iteration 0
  std::function<bool()> stopRequested;                     // polled before every evaluation (SIGINT)
};

// Minimises f over the box lower <= x <= upper (entries may be infinite) from
// x0, which is first projected into the box. See the file comment.
BfgsResult minimizeBfgs(const BfgsObjective& f, Eigen::VectorXd x0, const Eigen::VectorXd& lower,
                        const Eigen::VectorXd& upper, const BfgsOptions& options, const BfgsCallbacks& callbacks = {});

}  // namespace rodmesh
