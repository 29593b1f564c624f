// One number printed into a message, printf-style ("%.3g" and the like):
// the solvers' stop messages (solver/newton.cc, solver/minimizer.cc).
#pragma once

#include <cstdio>
#include <string>

namespace rodmesh {

inline std::string formatNumber(const char* fmt, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, a);
  return buf;
}

}  // namespace rodmesh
