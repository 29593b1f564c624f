// Static equilibrium of one pose: Newton's method on the total potential
// energy with a sparse LDL^T factorization and an Armijo backtracking line
// search. Where the Hessian is indefinite (buckling, snap-through) the step
// uses the modified factor L |D| L^T (a descent direction with the Hessian's
// own scaling); a diagonal shift is the last resort when the factorization
// fails. A converged state with negative curvature (a saddle, such as a
// perfectly straight column above its buckling load) is left along a
// direction of negative curvature, so that the solver ends at a stable
// equilibrium or says it could not.
//
// Convergence is judged on the force residual (PoseSystem::forceResidual, in
// newtons) relative to the pose's load scale: the residual of the undeformed
// configuration under the full load (point forces, weight and prescribed
// displacements). Nothing here is tuned to a particular scene.
#pragma once

#include "model/outcome.hh"
#include "model/pose_system.hh"

#include <Eigen/Core>
#include <string>
#include <vector>

namespace rodmesh {

struct NewtonOptions {
  int maxIterations = 100;        // per load step
  double tolerance = 1e-9;        // |residual| <= tolerance * load scale
  double armijo = 1e-4;           // sufficient-decrease constant
  int maxBacktracks = 30;         // halvings of the step per iteration
  double minShift = 1e-10;        // first diagonal shift tried (relative to diag(H))
  double maxShift = 1e12;         // give up beyond this shift
  int maxLoadHalvings = 10;       // continuation: smallest load step is 2^-maxLoadHalvings
  int maxEscapes = 20;            // steps along negative curvature away from unstable equilibria
  std::string isValid() const;    // empty if valid, else what is wrong
};

// Outcome of one Newton solve (one load step) or of a whole continuation.
struct NewtonReport {
  bool converged = false;           // outcome == Outcome::Converged
  Outcome outcome = Outcome::NumericalFailure;
  int iterations = 0;               // Newton iterations (all load steps)
  int loadSteps = 0;                // load steps taken (1 without continuation)
  int factorizations = 0;
  int hessianModifications = 0;     // iterations that needed a diagonal shift
  int backtracks = 0;               // step halvings in line searches
  double loadScale = 0.0;           // N
  double residualNorm = 0.0;        // N, final
  double relativeResidual = 0.0;    // residualNorm / loadScale
  bool roundoff = false;            // converged because the Newton correction reached round-off
  bool unstable = false;            // converged to an equilibrium with negative curvature
  int negativePivots = 0;           // of the last factorization (0: stable)
  int escapes = 0;                  // steps taken along negative curvature
  int chartUpdates = 0;             // iterations after which reference-frame charts moved
  double energy = 0.0;              // J, final
  double timeSeconds = 0.0;
  double assemblySeconds = 0.0, factorSeconds = 0.0;
  std::vector<double> residualHistory;  // relative residual per iteration
  std::string message;              // why it stopped
};

// Minimises the pose energy from u (updated in place) at the system's current
// load factor. `scale` is the load scale (N) used for the stopping test.
NewtonReport newtonSolve(PoseSystem& system, const Design& design, Eigen::VectorXd& u, double scale,
                         double tolerance, const NewtonOptions& options);

// Full static solve of one pose with adaptive load continuation: tries the
// full load first from `state` (its unknowns and charts: a warm start) and,
// if Newton fails, advances the load factor in smaller steps from the rest
// state. On exit `state` holds the solution, its charts and the load factor
// reached (1 unless the continuation gave up).
NewtonReport solveEquilibrium(PoseSystem& system, const Design& design, PoseState& state,
                              const NewtonOptions& options);
// The same from u with the charts at the design's rest frames (a solve from
// scratch); u: initial guess on entry (use PoseSystem::restDofs), solution on exit.
NewtonReport solveEquilibrium(PoseSystem& system, const Design& design, Eigen::VectorXd& u,
                              const NewtonOptions& options);

// The load scale of a pose (see above), in newtons.
double loadScale(PoseSystem& system, const Design& design);

}  // namespace rodmesh
