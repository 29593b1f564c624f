// Bound-constrained trust-region Newton-CG (Steihaug-Toint) for the
// reduced-space Newton method (docs/optimization.md, "Newton-CG"), written
// like solver/bfgs.hh for expensive objectives that may fail to evaluate:
// one value probe solves several equilibria, and each accepted point
// prepares exact Hessian-vector products (solver/reduced_hessian.hh) that
// then cost little each.
//
// One iteration at x (inside the box lo <= x <= hi) with gradient g and
// trust radius D (2-norm):
//  - Active set: a variable at a bound whose gradient points outward is held
//    for the iteration (its step is 0), as in solver/bfgs.hh.
//  - Step: truncated conjugate gradients on the model
//    m(s) = g's + s'Hs/2 over the free variables, from s = 0, stopped when
//      * the model gradient on the free variables falls below
//        eta |Pg|_2, eta = min(forcing, sqrt(|Pg|_2 / |Pg(x0)|_2)) (inexact
//        Newton: superlinear near a solution);
//      * the step reaches the trust radius (along the current direction);
//      * a direction of non-positive curvature is met: the step goes along it
//        to the trust radius (Steihaug), or, with gaussNewtonOnNegativeCurvature
//        and a Gauss-Newton product, the iteration's CG is run again with the
//        Gauss-Newton operator (positive semidefinite);
//      * maxCgIterations products were used.
//    Bounds are respected inside CG: when the step along a direction would
//    leave the box, it stops at the box, the variables it reached are held
//    at their bounds, and CG restarts from there on the remaining free
//    variables (the model keeps falling, every point stays feasible). So a
//    step may bind many bounds at once, not one per iteration.
//  - Ratio test: rho = (f(x) - f(x + s)) / (m(0) - m(s)) from one value
//    probe. Accepted when rho > acceptRatio and f falls: the gradient and
//    the products are prepared at x + s. D shrinks to shrink x |s| when
//    rho < 0.25 or the probe fails (no equilibrium), grows by grow (up to
//    maxRadius) when rho > 0.75 and the step reached the trust radius.
//
// Stopping tests at every accepted point, as in solver/bfgs.hh:
// |Pg|_inf <= gradientTolerance x scale (scale = gradientScale, or
// |Pg(x0)|_inf), the relative decrease over stallWindow iterations (not
// tested when the radius after the step is larger than after the last
// accepted step: the decrease was limited by a radius still growing),
// maxIterations (accepted steps), timeLimit and stopRequested (polled before
// every evaluation and every Hessian product of CG), Stalled when D falls below minRadius, NumericalFailure
// when x0 cannot be evaluated. The result is the last accepted point, which
// is the best point evaluated (steps are accepted only when f falls).
#pragma once

#include "model/outcome.hh"

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace rodmesh {

struct TrustRegionOptions {
  int maxIterations = 200;          // accepted steps
  double timeLimit = 0;             // s of wall-clock time, 0 = none
  double gradientTolerance = 1e-6;  // converged when |Pg|_inf <= gradientTolerance * gradient scale
  double gradientScale = 0;         // 0 = |Pg(x0)|_inf
  double relativeDecrease = 1e-9;   // converged when f fell by <= relativeDecrease * |f| ...
  int stallWindow = 5;              // ... over this many accepted steps
  double initialRadius = 1;         // trust radius (2-norm, variable units) at the start
  double maxRadius = std::numeric_limits<double>::infinity();
  double minRadius = 1e-9;          // Stalled when the radius falls below
  double acceptRatio = 1e-4;        // accept when actual / predicted decrease exceeds this
  double shrink = 0.25;             // radius = shrink * |s| after a poor or failed step
  double grow = 2;                  // radius *= grow after a very good step that reached it
  int maxCgIterations = 100;        // Hessian products per iteration (both operators together)
  double forcing = 0.5;             // largest relative CG residual
  bool gaussNewtonOnNegativeCurvature = false;

  std::string isValid() const;  // empty if valid
};

struct TrustRegionIterate {
  int iteration = 0;
  double f = 0;
  double projectedGradientNorm = 0;  // |Pg|_inf
  double step = 0;                   // |x_k - x_{k-1}|_2 of the accepted step
  double radius = 0;                 // trust radius after this iteration
  int cgIterations = 0;              // Hessian products of the accepted step's iteration
  int rejected = 0;                  // steps rejected (or failed) before it was found
  bool negativeCurvature = false;    // its CG met a direction of non-positive curvature
  bool gaussNewton = false;          // its step was computed with the Gauss-Newton operator
  double elapsed = 0;
  int evaluations = 0;               // value probes and gradient preparations so far
};

struct TrustRegionResult {
  Status status;
  Eigen::VectorXd x;
  double f = std::numeric_limits<double>::infinity();
  double projectedGradientNorm = 0;
  int iterations = 0, evaluations = 0, failedEvaluations = 0, rejectedSteps = 0;
  int cgIterations = 0;           // Hessian products in all
  int negativeCurvatureSteps = 0, gaussNewtonSteps = 0;
  double radius = 0;              // final trust radius
  double timeSeconds = 0;
  std::vector<TrustRegionIterate> history;  // from iteration 0
};

// The objective: value probes, and at accepted points the gradient and the
// Hessian products (at the point of the last successful `prepare`).
struct TrustRegionProblem {
  std::function<bool(const Eigen::VectorXd& x, double& f)> value;
  // Called at x after a successful value(x): gradient into g; false if it
  // cannot be had (the point is then rejected like a failed probe).
  std::function<bool(const Eigen::VectorXd& x, Eigen::VectorXd& g)> prepare;
  std::function<Eigen::VectorXd(const Eigen::VectorXd& v)> hessian;
  std::function<Eigen::VectorXd(const Eigen::VectorXd& v)> gaussNewton;  // optional
};

struct TrustRegionCallbacks {
  std::function<void(const Eigen::VectorXd& x)> accepted;
  std::function<void(const TrustRegionIterate&)> progress;  // once per iteration, including iteration 0
  std::function<bool()> stopRequested;
};

TrustRegionResult minimizeTrustRegion(const TrustRegionProblem& problem, Eigen::VectorXd x0,
                                      const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                      const TrustRegionOptions& options, const TrustRegionCallbacks& callbacks = {});

// One step of the above (exposed for tests): truncated CG for the model
// g's + s'Hs/2 with |s|_2 <= radius and lower <= x + s <= upper, variables
// with `held` set kept at 0. See the file comment.
struct TrustRegionStep {
  Eigen::VectorXd s;
  double predicted = 0;           // m(0) - m(s) >= 0
  int cgIterations = 0;
  bool reachedRadius = false, negativeCurvature = false;
  bool stopped = false;  // `stop` answered true before a product
};
TrustRegionStep steihaugStep(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& hessian,
                             const Eigen::VectorXd& x, const Eigen::VectorXd& g, const Eigen::VectorXd& lower,
                             const Eigen::VectorXd& upper, std::vector<char> held, double radius, double tolerance,
                             int maxIterations, const std::function<bool()>& stop = {});

}  // namespace rodmesh
