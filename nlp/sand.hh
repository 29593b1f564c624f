// Simultaneous analysis and design (SAND) with Ipopt: every pose's
// equilibrium is an equality constraint of one nonlinear program whose
// variables are the unknowns of all poses and the design values of the
// current schedule phase (nlp/sand_nlp.hh). Exact Jacobians and exact
// Hessians of the Lagrangian; MUMPS solves Ipopt's linear systems.
//
// This header does not include Ipopt; nothing outside nlp/ does.
//
// A run: equilibria of the initial design by Newton (the starting point),
// then one Ipopt solve per schedule phase (the same schedule as the reduced
// method, solver/design_optimizer.hh), each started from the previous phase's
// design and equilibria. After every phase the poses are re-solved by Newton
// from Ipopt's positions under Ipopt's design; the phase's design is kept only
// if those equilibria exist and the objective did not rise, so the result is
// always the best design found, with true equilibria. The kept phase designs
// are the run's fallbacks (solver/design_fallback.hh) should the final one not
// re-solve from rest.
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
  // The retry of a diverged phase keeps its iterates within this 1-norm of
  // the scaled constraints (Ipopt's theta_max_fact, default 1e4): steps that
  // leave equilibrium further are cut by the filter line search.
  double retryThetaMaxFact = 1e-2;
  // Relative tolerance of a phase that a finer phase continues (radius
  // levels before the last phase), or --tol if looser.
  double handOverTolerance = 1e-3;
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

DesignOptimizerResult optimizeSand(SceneModel& model, const DesignSpace& space, const SandOptions& options,
                                   const DesignProgress& progress = {});

}  // namespace rodmesh
