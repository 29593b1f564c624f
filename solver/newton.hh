// Static equilibrium of one pose: Newton's method on the total potential
// energy with a sparse LDL^T factorization, an Armijo backtracking line
// search, and a diagonal shift that keeps every step a descent direction when
// the Hessian is indefinite (buckling, snap-through).
//
// Convergence is judged on the force residual (PoseSystem::forceResidual, in
// newtons) relative to the pose's load scale: the residual of the undeformed
// configuration under the full load (point forces, weight and prescribed
// displacements). Nothing here is tuned to a particular scene.
#pragma once

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
  std::string isValid() const;    // empty if valid, else what is wrong
};

// Outcome of one Newton solve (one load step) or of a whole continuation.
struct NewtonReport {
  bool converged = false;
  int iterations = 0;               // Newton iterations (all load steps)
  int loadSteps = 0;                // load steps taken (1 without continuation)
  int factorizations = 0;
  int hessianModifications = 0;     // iterations that needed a diagonal shift
  int backtracks = 0;               // step halvings in line searches
  double loadScale = 0.0;           // N
  double residualNorm = 0.0;        // N, final
  double relativeResidual = 0.0;    // residualNorm / loadScale
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
// full load first and, if Newton fails, advances the load factor in smaller
// steps. u: initial guess on entry (use PoseSystem::restDofs), solution on exit.
NewtonReport solveEquilibrium(PoseSystem& system, const Design& design, Eigen::VectorXd& u,
                              const NewtonOptions& options);

// The load scale of a pose (see above), in newtons.
double loadScale(PoseSystem& system, const Design& design);

}  // namespace rodmesh
