// Outcome of a solve or an optimisation: one enum with a message, shared by
// Newton, both optimisers, the command line and the archive writer; the
// summary every pose solve reports.
#pragma once

#include <string>

namespace rodmesh {

enum class Outcome {
  Converged,         // the stopping test was met
  MaxIterations,     // iteration limit reached first
  TimeLimit,         // wall-clock limit reached first
  Interrupted,       // SIGINT / SIGTERM, or a caller's stop request
  Stalled,           // no further progress possible (line search, step size, load step)
  NumericalFailure,  // non-finite values, failed factorization, solver breakdown
  InvalidProblem,    // the problem has no solution as posed (e.g. unsupported, unbalanced loads)
};

inline const char* outcomeName(Outcome o) {
  switch (o) {
    case Outcome::Converged: return "converged";
    case Outcome::MaxIterations: return "max_iterations";
    case Outcome::TimeLimit: return "time_limit";
    case Outcome::Interrupted: return "interrupted";
    case Outcome::Stalled: return "stalled";
    case Outcome::NumericalFailure: return "numerical_failure";
    case Outcome::InvalidProblem: return "invalid_problem";
  }
  return "unknown";
}

// The archive's `status` (contract §3): converged, not_converged or failed.
inline const char* archiveStatus(Outcome o) {
  switch (o) {
    case Outcome::Converged: return "converged";
    case Outcome::NumericalFailure:
    case Outcome::InvalidProblem: return "failed";
    default: return "not_converged";
  }
}

struct Status {
  Outcome outcome = Outcome::NumericalFailure;
  std::string message;
  bool converged() const { return outcome == Outcome::Converged; }
};

// What every solve of a pose reports: the static Newton solve and its loading
// path (solver/newton.hh NewtonReport), a dynamic run (solver/dynamics.hh
// DynamicsReport) and dynamic relaxation (solver/relaxation.hh
// RelaxationReport) extend it with their own counters; the archive writer
// records it per pose. converged() is the outcome, never a separate flag.
struct SolveSummary {
  Outcome outcome = Outcome::NumericalFailure;
  // The returned state is finite and answers the problem posed, if perhaps
  // not to tolerance (an iteration limit): for a static solve, an
  // equilibrium at the full load (false for the rest state or an equilibrium
  // at a partial load, loadFactor says which); for a dynamic run, the state
  // at the time it reached.
  bool usable = false;
  int iterations = 0;             // Newton iterations (all load steps, all time steps)
  double residualNorm = 0.0;      // N, force residual of the returned state
  double relativeResidual = 0.0;  // residualNorm / loadScale
  double loadScale = 0.0;         // N, the reference of the stopping test
  double loadFactor = 1.0;        // of the returned state
  double timeSeconds = 0.0;       // wall clock
  double assemblySeconds = 0.0, factorSeconds = 0.0;
  std::string message;            // why it stopped

  bool converged() const { return outcome == Outcome::Converged; }
  // One line: outcome, iterations, residual, load factor when partial, time.
  std::string brief() const;
  // Several lines: the brief, the message and the time split.
  std::string report() const;
};

}  // namespace rodmesh
