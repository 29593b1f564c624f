// Static equilibrium of one pose: Newton's method on the total potential
// energy with a sparse LDL^T factorization and an Armijo backtracking line
// search. Where the Hessian is indefinite (buckling, snap-through) the step
// uses the modified factor L |D| L^T (a descent direction with the Hessian's
// own scaling); pivots at the round-off level of their own rows (mechanisms:
// a rod free to swing about a pin, a sheet hinged on a line of pinned
// vertices) are floored there (solver/modified_ldlt.hh). Every step is
// limited to a trust radius on the vertex displacements (the structure's size
// to start with, grown after full steps it limited, shrunk to what the line
// search accepted), so that a zero-stiffness direction cannot throw the state
// to infinity. A diagonal shift is the last resort when the factorization
// fails. A converged state with negative curvature (a saddle, such as a
// perfectly straight column above its buckling load) is left along a
// direction of negative curvature, so that the solver ends at a stable
// equilibrium or says it could not.
//
// Convergence is judged on the force residual r (PoseSystem::forceResidual,
// in newtons) and is met in one of three ways (NewtonReport::message says
// which):
//   1. |r| <= tolerance * load scale, the load scale being the residual of the
//      undeformed configuration under the full load (point forces, weight,
//      prescribed displacements), and, with an unmodified factorization and
//      r above its round-off floor (2.), a Newton correction (the first-order
//      position error) that moves no vertex by more than tolerance * the
//      structure's size: along a soft mode the residual alone would pass
//      large errors (r / stiffness);
//   2. the round-off floor: |r| <= the residual that rounding the unknowns to
//      double precision alone produces, estimated from the actual stiffness and
//      unknowns as  rho_i = eps sqrt(sum_j H_ij^2 a_j^2),  a_j = |u_j| + s_j
//      (s_j: the mean edge length for a coordinate, 1 rad for a twist), AND
//      the Newton decrement -g.d is no larger than the energy of that
//      rounding, eps^2 sum_ij |H_ij| a_i a_j. The second condition keeps a
//      smooth, low-mode error (a tip that is still off) from passing as
//      noise: its residual can be as small as round-off while its decrement is
//      orders of magnitude larger (5,001-vertex gravity cantilever: floor
//      1.1e-2 N, reached residual 2.1e-3 N, decrement at the floor 2.5e-19 J,
//      round-off energy 8e-18 J, decrement one iteration earlier 4e-13 J);
//   3. the Newton correction is below the resolution of every unknown
//      (|d_i| <= 4 eps |u_i|) with an unmodified factorization.
// Nothing here is tuned to a particular scene. The Newton iteration itself is
// the one energy minimizer of solver/minimizer.hh, which the backward-Euler
// step (solver/dynamics.hh) shares.
#pragma once

#include <atomic>

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "model/outcome.hh"
#include "model/pose_system.hh"

namespace rodmesh {

struct NewtonOptions {
  int maxIterations = 100;      // per load step
  double tolerance = 1e-9;      // |residual| <= tolerance * load scale
  double armijo = 1e-4;         // sufficient-decrease constant
  int maxBacktracks = 30;       // halvings of the step per iteration
  double minShift = 1e-10;      // first diagonal shift tried (relative to diag(H))
  double maxShift = 1e12;       // give up beyond this shift
  int maxLoadHalvings = 10;     // continuation: smallest load step is 2^-maxLoadHalvings
  int maxEscapes = 20;          // steps along negative curvature away from unstable equilibria
  double timeLimit = 0.0;       // s of wall-clock time for a whole solveEquilibrium; 0: none
  // Follow the loading path from rest (see solveEquilibrium); false: the full
  // load at once from the given state, continuation only when Newton fails
  // (any equilibrium Newton finds; kept for comparisons).
  bool loadingPath = true;
  // A load step is on the path when its converged state lies within this
  // fraction of the predicted displacement from the prediction (the secant
  // through the path's last two equilibria, or the tangent for the first
  // step; see solveEquilibrium).
  double pathDeviation = 1.0;
  // Set by another thread to stop a solve early (checked where the time
  // limit is; the solve then ends as if its time limit had passed).
  const std::atomic<bool>* cancel = nullptr;
  std::string isValid() const;  // empty if valid, else what is wrong
};

// A point of the loading path where the equilibrium lost its stability (a
// limit or bifurcation point): the structure leaves the branch it was on.
struct CriticalPoint {
  double loadFactor = 0.0;          // last load factor on the branch before it
  double smallestEigenvalue = 0.0;  // N/m, of the stiffness there (near zero at the critical point)
  double jump = 0.0;                // m, largest vertex displacement to the equilibrium beyond it
};

// Outcome of one Newton solve (one load step) or of a whole continuation:
// the summary every solve reports (model/outcome.hh: outcome, usable state,
// iterations, residual, load scale and factor, timings, message) and
// Newton's own counters.
struct NewtonReport : SolveSummary {
  int loadSteps = 0;         // load steps taken (1 without continuation), resumed runs included
  int resumes = 0;           // full-load runs resumed after their iteration limit (still progressing)
  // A mechanism's swing completed under its loads times this factor, then
  // brought back to the given loads (0: not needed; see solveEquilibrium).
  double mechanismScale = 0.0;
  bool progressing = false;  // stopped at the iteration limit while still descending steadily
  int factorizations = 0;
  int hessianModifications = 0;   // iterations that needed a diagonal shift
  int backtracks = 0;             // step halvings in line searches
  bool roundoff = false;          // converged because the Newton correction reached round-off
  bool unstable = false;          // stopped at an equilibrium with negative curvature (a saddle: not converged)
  int negativePivots = 0;         // of the last factorization (0: stable)
  int negativeIterations = 0;     // iterations whose Hessian had negative pivots (met negative curvature)
  std::vector<CriticalPoint> criticalPoints;  // passed on the loading path, in load order
  int singularPivots = 0;         // of the last factorization: pivots at round-off (zero-stiffness modes)
  double roundoffFloor = 0.0;     // N, estimated force residual of round-off at the final state (rule 2 above)
  double smallestEigenvalue = std::numeric_limits<double>::quiet_NaN();  // N/m, when the path was lost (see below)
  int escapes = 0;                                                       // steps taken along negative curvature
  int chartUpdates = 0;  // iterations after which reference-frame charts moved
  double energy = 0.0;   // J, final
  std::vector<double> residualHistory;  // relative residual per iteration
};

// Minimises the pose energy from state.u at state.loadFactor; the state's
// unknowns and charts (re-anchored where edges turned far) are updated in
// place. `scale` is the load scale (N) used for the stopping test.
NewtonReport newtonSolve(const PoseSystem& system, const Design& design, PoseState& state, double scale,
                         double tolerance, const NewtonOptions& options);

// Full static solve of one pose: the stable equilibrium the structure reaches
// when its loads (forces, moments, weight and prescribed displacements, all
// scaled by one load factor) are applied quasi-statically from rest.
//
// From a state below the full load (the rest state for a solve from scratch)
// the load factor is advanced from the state's to 1 in steps as long as the
// path allows: the full load in one step first (easy scenes cost one Newton
// solve), shorter steps where a step is not on the path. A step is on the
// path when its Newton corrector never meets negative curvature and lands
// within NewtonOptions::pathDeviation of the predicted displacement from
// the prediction: the tangent (the first Newton step from the last
// equilibrium) for the path's first step and the first after a critical
// point, otherwise the secant through the last two equilibria, from which
// the corrector starts;
// steps are halved when not, doubled when the prediction was good. Where no
// step of 2^-maxLoadHalvings stays on the branch (a limit or bifurcation
// point) the structure leaves it as a rising load makes it: one unrestricted
// solve just beyond, which escapes along negative curvature (a snap-through,
// or buckling into a lateral mode); the point, its smallest stiffness
// eigenvalue and the jump are reported (NewtonReport::criticalPoints) and the
// path goes on from there. Converged always means a stable equilibrium (no
// negative pivot in the final factorization).
//
// A state given at the full load (state.loadFactor == 1: an optimizer's warm
// start, the equilibrium of a nearby design or SAND's approximation of one)
// is continued in the design: Newton from it, kept when it converges to a
// stable state; otherwise the loading path from rest decides. Whether a
// design's continued equilibria are the loading path's is judged once, on
// the design an optimizer archives (solver/design_fallback.hh).
//
// A structure with a zero-stiffness mode at rest (a mechanism) cannot be
// loaded gradually (smaller loads need the same large motion): the full load
// from rest is its answer. When Newton does not complete the swing under
// loads far below the stiffness and no held vertex moves, the loads are
// scaled up (100, 1e4, 1e6 times), solved from rest, and brought back to
// the given ones (NewtonReport::mechanismScale). NewtonOptions::loadingPath = false restores the
// full load at once from the given state, with continuation only when Newton
// fails.
//
// When the continuation cannot advance at all (no equilibrium within
// 2^-maxLoadHalvings beyond a load factor), the state returned is the
// equilibrium at the last load factor reached, report.loadFactor says which,
// the outcome is not Converged, and the message says so. If the stiffness
// there has (nearly) lost its positive definiteness, or the failed steps
// beyond it met negative curvature, the message reads "the equilibrium path
// was lost at load factor X (a limit or bifurcation point; smallest stiffness
// eigenvalue Y N/m ...)" and report.smallestEigenvalue holds Y.
//
// Non-finite loads (a load scale that overflows) or non-finite energies and
// forces end with Outcome::NumericalFailure, never Converged.
NewtonReport solveEquilibrium(const PoseSystem& system, const Design& design, PoseState& state,
                              const NewtonOptions& options);
// The same from u with the charts at the design's rest frames (a solve from
// scratch); u: initial guess on entry (use PoseSystem::restDofs), solution on
// exit. The solution's charts are not returned: use the PoseState overload
// where they matter (material twists, a warm start).
NewtonReport solveEquilibrium(const PoseSystem& system, const Design& design, Eigen::VectorXd& u,
                              const NewtonOptions& options);

// The load scale of a pose (see above), in newtons (+inf when the loads
// overflow double precision): the force residual of the design's rest state
// under the full load (where that is not finite, e.g. a held vertex
// prescribed past its neighbour, the residual at the largest load factor
// 2^-k where it is, over 2^-k).
double loadScale(const PoseSystem& system, const Design& design);

// Stability of a state (at its load factor and charts):
// inertia of the Hessian and its eigenvalue of smallest magnitude, in N/m
// (twist unknowns expressed as arc lengths theta * momentArm, so that every
// entry is a stiffness against a displacement), by inverse iteration.
struct Stability {
  bool ok = false;   // false: the Hessian could not be factorized
  int negative = 0;  // negative eigenvalues (0: stable)
  double smallestEigenvalue = 0.0;
  double largestDiagonal = 0.0;  // N/m, of the same (scaled) Hessian
  // A zero-stiffness mode (a mechanism, or rigid motion of an unsupported
  // structure): |smallest eigenvalue| at the round-off of the largest
  // diagonal entry (kPivotRoundoff eps, solver/modified_ldlt.hh).
  bool zeroMode() const;
};
Stability stability(const PoseSystem& system, const Design& design, const PoseState& state);

// A stable equilibrium whose smallest stiffness eigenvalue is at most this
// fraction of the unloaded structure's (the rest state under the same
// supports) has lost nearly all its stiffness along one mode: it is at, or
// next to, a limit or bifurcation point. Near a limit point the eigenvalue
// falls like the square root of the load's distance to it (a load margin of
// the order of the ratio squared), before a bifurcation linearly (of the
// order of the ratio). The loading path uses the same ratio to tell a
// critical point from a merely soft state.
constexpr double kCriticalStiffnessRatio = 1e-2;

// Round-off floor of the force residual at u (rule 2 above), in newtons,
// from the Hessian at u (lower triangle, PoseSystem::evaluate).
double roundoffFloor(const PoseSystem& system, const Eigen::SparseMatrix<double>& hessian, const Eigen::VectorXd& u);

}  // namespace rodmesh
