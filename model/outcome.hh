// Outcome of a solve or an optimisation: one enum with a message, shared by
// Newton, both optimisers, the command line and the archive writer.
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

}  // namespace rodmesh
