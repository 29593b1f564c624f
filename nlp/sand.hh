// Simultaneous analysis and design (SAND) with Ipopt: every pose's
// equilibrium is an equality constraint of one nonlinear program whose
// variables are the unknowns of all poses and the design values of the
// current schedule phase (nlp/sand_nlp.hh). Exact Jacobians and exact
// Hessians of the Lagrangian; MUMPS solves Ipopt's linear systems.
//
// This header does not include Ipopt; nothing outside nlp/ does.
//
// A run is the design driver's (solver/design_driver.hh): the schedule,
// limits, phase ends, fallbacks and outcome are written there once. SAND's
// part is the phase: one Ipopt solve started from the best design so far and
// its equilibria, whose final point and best nearly feasible iterate the
// driver polishes by Newton and keeps when the objective did not rise.
#pragma once

#include "solver/design_optimizer.hh"

#include <string>
#include <utility>
#include <vector>

namespace rodmesh {

struct SandOptions {
  DesignOptimizerOptions optimizer;  // iterations, time limit, tolerance, schedule, threads, Newton, stop
  // Ipopt options applied after the defaults and after ipopt.opt (if any in
  // the working directory), in this order; checked by checkIpoptOption.
  std::vector<std::pair<std::string, std::string>> ipopt;
  bool readOptionsFile = true;  // read ./ipopt.opt when present
  // A phase is diverging when `divergedIterates` iterates in a row are off
  // equilibrium by more than `divergedLoads` times the largest pose load (N),
  // or an iterate's dual infeasibility exceeds `divergedDualInfeasibility`.
  // Far from equilibrium the linearised constraints are poor (a step that
  // moves part of a sheet out of plane by an edge length changes edge
  // lengths at second order), the iterates rarely come back and the KKT
  // factorizations grow slower; runs that do recover leave it for single
  // iterations only (docs/optimization.md, "SAND phases that diverge").
  double divergedLoads = 100.0;
  int divergedIterates = 3;
  double divergedDualInfeasibility = 1e10;
  // Also when `wanderingIterates` iterates in a row are none of them nearly
  // feasible (off equilibrium by more than 1e-3 of the smallest pose load):
  // iterates that stay tens of loads off equilibrium, below the threshold
  // above, can wander for the whole iteration cap without coming back, and
  // the phase's best nearly feasible iterate is then the one to go on from.
  int wanderingIterates = 200;
  // Also when `divergedIterates` iterates in a row needed a Hessian
  // regularization (Ipopt's delta_w, on the scaled variables) of at least
  // `divergedRegularization` at a dual infeasibility of at least
  // `regularizedDualInfeasibility`: the Lagrangian's Hessian is then far
  // from positive on the constraints' null space (multipliers grown huge),
  // Ipopt's steps are short regularized ones and every iteration costs a
  // dozen factorizations, which grow slow (docs/optimization.md, "SAND
  // phases that diverge").
  double divergedRegularization = 1e4;
  double regularizedDualInfeasibility = 1e6;
  // The retry of a diverged phase keeps its iterates within this 1-norm of
  // the scaled constraints (Ipopt's theta_max_fact, default 1e4): steps that
  // leave equilibrium further are cut by the filter line search.
  double retryThetaMaxFact = 1e-2;
  // The retry of a diverged phase is run by the reduced method's Newton-CG
  // phase solver (every iterate an equilibrium, exact Hessian products)
  // instead of Ipopt held near equilibrium by retryThetaMaxFact: on targets
  // no rod mesh reaches, Ipopt's rest-shape iterates leave equilibrium by
  // thousands of newtons also when held (docs/optimization.md, "SAND phases
  // that diverge").
  bool newtonRetry = true;
  // Relative tolerance of a phase that a finer phase continues (radius
  // levels before the last phase), or --tol if looser.
  double handOverTolerance = 1e-3;
  // The first phase starts with at most this many iterations of the reduced
  // method's BFGS on the same variables (0: none), ending earlier when
  // `warmupWindow` iterations lowered the objective by less than
  // `warmupRelativeDecrease` of its value; Ipopt then continues the phase from
  // the best design found. Every BFGS iterate is an equilibrium and the first
  // steps are the large ones, so the run holds a good design within seconds,
  // where Ipopt's first iterates leave equilibrium and regain it only after
  // tens of iterations (docs/optimization.md, "SAND's first phase").
  int warmupIterations = 10;
  int warmupWindow = 2;
  double warmupRelativeDecrease = 0.1;
  // Empty if valid (the optimizer's options, these, and every Ipopt option
  // by checkIpoptOption), else what is wrong.
  std::string isValid() const;
};

// Empty if Ipopt has an option `key` and `value` is valid for it (type and
// range) and usable in this build (linear_solver: mumps only; no HSL
// scaling); otherwise a one-line reason naming both.
std::string checkIpoptOption(const std::string& key, const std::string& value);

// Whether ./ipopt.opt exists (Ipopt reads it; its options override the defaults).
bool ipoptOptionsFilePresent();
// Empty if ./ipopt.opt is absent, or a regular file of lines KEY VALUE
// ('#' comments) each of which checkIpoptOption accepts; otherwise why not,
// naming the file, the line, the key and the value (nlp/ipopt_options.cc).
std::string checkIpoptOptionsFile();

DesignOptimizerResult optimizeSand(const SceneModel& model, const DesignSpace& space, const SandOptions& options,
                                   const DesignProgress& progress = {});

}  // namespace rodmesh
