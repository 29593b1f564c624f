#include "model/outcome.hh"

#include <cstdio>

namespace rodmesh {

std::string SolveSummary::brief() const {
  char buf[256];
  int k = std::snprintf(buf, sizeof buf, "%s after %d iteration%s, residual %.3g N", outcomeName(outcome), iterations,
                        iterations == 1 ? "" : "s", residualNorm);
  if (loadScale > 0 && k > 0 && k < static_cast<int>(sizeof buf))
    k += std::snprintf(buf + k, sizeof buf - k, " (%.3g of the load)", relativeResidual);
  if (loadFactor < 1.0 && k > 0 && k < static_cast<int>(sizeof buf))
    k += std::snprintf(buf + k, sizeof buf - k, ", at load factor %.4g", loadFactor);
  if (k > 0 && k < static_cast<int>(sizeof buf))
    std::snprintf(buf + k, sizeof buf - k, ", %.3g s%s", timeSeconds, usable ? "" : " (state not usable)");
  return buf;
}

std::string SolveSummary::report() const {
  std::string out = brief();
  if (!message.empty()) out += "\n  " + message;
  char buf[160];
  std::snprintf(buf, sizeof buf, "\n  time %.3g s: assembly %.3g s, factorization %.3g s", timeSeconds, assemblySeconds,
                factorSeconds);
  return out + buf;
}

}  // namespace rodmesh
