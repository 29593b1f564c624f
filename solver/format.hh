// Numbers printed into the solvers' messages, printf-style ("%.3g" and the
// like): the stop messages of solver/newton.cc, solver/minimizer.cc,
// solver/bfgs.cc and solver/trust_region.cc. formatMessage is declared with
// the printf format attribute, so the compiler checks every call's
// arguments against its format string.
#pragma once

#include <cstdarg>
#include <cstdio>
#include <string>

namespace rodmesh {

[[gnu::format(printf, 1, 2)]] inline std::string formatMessage(const char* fmt, ...) {
  char buf[512];
  va_list ap;
  va_start(ap, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  return buf;
}

inline std::string formatNumber(const char* fmt, double a) { return formatMessage(fmt, a); }

}  // namespace rodmesh
