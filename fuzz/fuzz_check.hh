// Shared by the libFuzzer harnesses: what every rejection must look like.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>

namespace rodmesh::fuzz {

// A rejection is one line that starts with the name of the input ("FILE: ").
// Anything else is a finding: print it and abort, so that libFuzzer keeps the input.
inline void checkMessage(const std::string& message, const std::string& file) {
  const bool oneLine = message.find('\n') == std::string::npos;
  const bool named = message.rfind(file + ":", 0) == 0;
  if (oneLine && named) return;
  std::fprintf(stderr, "bad rejection message (%s): %s\n", oneLine ? "does not name the file" : "several lines",
               message.c_str());
  std::abort();
}

// A property that must hold for every accepted input.
inline void require(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "property violated: %s\n", what);
  std::abort();
}

}  // namespace rodmesh::fuzz
