// The one energy minimizer of rodmesh: Newton's method on a pose's total
// potential energy, serving both the static solve (solver/newton.hh, at a
// load factor of the loading path) and the backward-Euler time step
// (solver/dynamics.hh, whose incremental potential adds an inertia term).
//
// It minimises
//   Phi(u) = E(u)                                          (statics), or
//   Phi(u) = E(u) + 1/(2 h^2) (u - u_pred)^T M (u - u_pred)  (a time step)
// from the state's unknowns at the state's load factor, with a sparse LDL^T
// factorization of the Hessian (solver/modified_ldlt.hh: L |D| L^T where it
// is indefinite, zero-stiffness pivots floored at round-off, a diagonal shift
// as the last resort), an Armijo backtracking line search, optionally a trust
// radius on the vertex displacements and steps along negative curvature away
// from saddles. Its stopping tests are those documented in solver/newton.hh:
// (1) |r| <= tolerance * scale (for statics with a Newton correction within
// tolerance * size); (2) r at the round-off floor with a Newton
// decrement below the energy of rounding the unknowns (the inertia term's
// own round-off added for a time step); (3) a Newton correction below the
// resolution of every unknown. The settings say which of the two problems is
// solved; everything else is the same code.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <atomic>
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "model/pose_system.hh"
#include "solver/modified_ldlt.hh"
#include "solver/newton.hh"

namespace rodmesh {

// The inertia term of a backward-Euler step of size h:
// 1/(2 h^2) (u - predicted)^T diag(mass) (u - predicted).
struct InertiaTerm {
  const Eigen::VectorXd* mass = nullptr;  // per unknown (kg on coordinates, zero on twists)
  double invH2 = 0.0;                     // 1 / h^2
  Eigen::VectorXd predicted;              // u_n + h v_n
  double energy(const Eigen::VectorXd& u) const {
    return 0.5 * invH2 * (mass->array() * (u - predicted).array().square()).sum();
  }
};

struct MinimizerSettings {
  double scale = 0.0;           // N: the residual reference of the stopping test (1)
  bool scaleFromStart = false;  // the reference is instead the residual at the starting point
  double tolerance = 1e-9;      // test (1)
  int maxIterations =
      100;                 // Newton iterations; then MaxIterations (report.progressing says whether it still descended)
  double armijo = 1e-4;    // sufficient-decrease constant
  int maxBacktracks = 30;  // step halvings per line search
  double minShift = 1e-10, maxShift = 1e12;  // the diagonal shift's range (relative to diag)
  // Converged only at a positive definite Hessian: a saddle is left along
  // negative curvature (at most maxEscapes times) and is never a solution.
  // false: a point that meets test (1) is the answer whatever its curvature
  // (a time step, whose inertia term makes the Hessian definite for small h).
  bool stableOnly = true;
  int maxEscapes = 20;
  bool trustRegion = true;               // limit steps to a trust radius on the vertex displacements
  bool reanchor = true;                  // re-anchor charts of edges that turned far (solver-internal coordinates)
  bool stopAtNegative = false;           // stop (Stalled, "met negative curvature") at the first negative pivot
  // Stop (Stalled, "left Newton's region of convergence") at the first
  // iteration whose force residual is not below the previous one's, or
  // whose line search shortens the Newton step: a corrector from a predicted
  // state that is not converging quadratically (the caller shortens the step).
  bool stopOutsideNewtonRegion = false;
  Eigen::VectorXd* firstStep = nullptr;  // receives the first unmodified Newton step (the tangent prediction)
  const InertiaTerm* inertia = nullptr;  // the time step's inertia term; null for statics
  std::optional<std::chrono::steady_clock::time_point> deadline;  // then TimeLimit
  const std::atomic<bool>* cancel = nullptr;                      // set by another thread: TimeLimit
};

// Buffers that a caller minimizing many times on one pose model keeps between
// calls (the Hessian, the time step's matrix and the factorization, whose
// symbolic analysis is then reused).
struct MinimizerWorkspace {
  Eigen::SparseMatrix<double> hessian;  // of E (lower triangle, full diagonal)
  Eigen::SparseMatrix<double> matrix;   // of Phi: the Hessian plus the inertia diagonal
  std::vector<int> diagonal;            // position of each diagonal entry in matrix's values
  ModifiedLdlt factor;
};

// Minimises Phi from state.u; state.u (and state.charts, where re-anchored)
// are updated in place. The report's energy is Phi's.
NewtonReport minimizeEnergy(const PoseSystem& system, const Design& design, PoseState& state,
                            const MinimizerSettings& settings, MinimizerWorkspace& workspace);

// Largest vertex displacement of a step (Euclidean per vertex), m.
double maxVertexStep(const PoseSystem& system, const Eigen::VectorXd& step);
// Diagonal of the structure's bounding box in a state (at least one mean edge), m.
double structureSize(const PoseSystem& system, const Design& design, const PoseState& state);

}  // namespace rodmesh
