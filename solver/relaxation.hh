// Static equilibrium of one pose by dynamic relaxation with kinetic damping:
// the paper's static solver (§4, "Simulation", after Volino and
// Magnenat-Thalmann 2007), kept as an alternative to Newton
// (solver/newton.hh) and as its baseline in benchmarks/network_bench.cc.
//
// Pseudo-dynamics of all unknowns u (positions and twists) with fictitious
// masses, integrated explicitly (leapfrog, symplectic Euler):
//   v <- v + h M^-1 f(u),   u <- u + h v,   f = -grad E.
// The masses make the step stable and the convergence rate independent of
// the units and stiffness contrasts (Barnes' mass scaling): with h0 = 1,
//   m_i = massSafety * sum_j |H_ij|      (Gershgorin row sum of the Hessian),
// so that h0 * omega_max <= 1 / sqrt(massSafety), inside the explicit limit 2
// for massSafety > 1/4. The masses are refreshed from the current Hessian at
// a kinetic-energy peak at most every massUpdateInterval iterations.
// Kinetic damping: whenever the kinetic energy 1/2 v^T M v decreases, its
// peak has just been passed; the motion stops there (v = 0) and restarts
// from rest. Adaptive time step: h grows by stepGrowth after every stable
// cycle (up to maxStep) and halves, from the cycle's start, when a cycle
// turns unstable (the potential energy rises above its value at the start of
// the cycle by more than half the cycle's peak kinetic energy, or becomes
// non-finite).
//
// Convergence: the same test as Newton, on the same force residual
// (PoseSystem::forceResidual): |r| <= tolerance * load scale (loadScale in
// solver/newton.hh), or |r| <= PoseSystem::roundoffForce.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "model/outcome.hh"
#include "model/pose_system.hh"

namespace rodmesh {

struct RelaxationReport;

struct RelaxationOptions {
  int maxIterations = 1000000;  // force evaluations
  double tolerance = 1e-9;      // |residual| <= tolerance * load scale
  double timeLimit = 0.0;       // s of wall-clock time; 0: none
  double massSafety = 0.5;      // fictitious mass = massSafety * Gershgorin row sum (> 1/4 for stability)
  double initialStep = 1.0;     // pseudo-time step, in units of the mass-scaling step h0 = 1
  double maxStep = 1.9;         // largest pseudo-time step
  double minStep = 1e-6;        // the solver gives up below this step
  double stepGrowth = 1.1;      // per stable kinetic-energy cycle
  int massUpdateInterval = 10;  // iterations between refreshes of the fictitious masses
  int historyStride = 1;        // record every n-th residual (the last one always)
  // Called every progressInterval seconds of wall clock with the report so
  // far (iterations, residualNorm, relativeResidual, timeSeconds, finalStep =
  // the current step); empty: never.
  std::function<void(const RelaxationReport&)> progress;
  double progressInterval = 2.0;  // s
  std::string isValid() const;  // empty if valid, else what is wrong
};

// A relaxation: the summary every solve reports (model/outcome.hh;
// iterations are force evaluations) and the relaxation's own counters.
struct RelaxationReport : SolveSummary {
  int restarts = 0;       // kinetic-energy peaks
  int instabilities = 0;  // cycles restarted with a halved step
  int massUpdates = 0;
  int chartUpdates = 0;
  double finalStep = 0.0;     // pseudo-time step at the end
  double energy = 0.0;  // J, final
  // Residual history: relative residual, at iteration, at elapsed seconds.
  std::vector<double> residualHistory;
  std::vector<int> historyIteration;
  std::vector<double> historySeconds;
};

// Full static solve of one pose at load factor 1 from u (use
// PoseSystem::restDofs), updated in place, its twists measured from the
// design's rest frames at the start. `charts`, if given, receives the charts
// of the returned u (they move where edges turn far).
RelaxationReport relaxEquilibrium(const PoseSystem& system, const Design& design, Eigen::VectorXd& u,
                                  const RelaxationOptions& options, Charts* charts = nullptr);

}  // namespace rodmesh
